"""Whether a network has heights (`Network.heights`), from each source, kept by its folder
and its GeoJSON export. References: the closed-form heights of the test netelement
(`tests.support.height_networks`), the shipped files' own coordinates (2-D)."""
from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.support.height_networks import ELEMENT, height_m, write_geojson
from trackmodel.errors import TrackFileError
from trackmodel.fit_defaults import DEFAULT_VTOL_M
from trackmodel.network import Network
from trackmodel.network_folder import HEIGHTS_COLUMN
from trackmodel.network_io import (
    read_network,
    read_network_geojson,
    write_network,
    write_network_geojson,
)
from trackmodel.network_routes import load_network

DATA = Path(__file__).resolve().parents[2] / "data"
#: The heights of an exported GeoJSON are rounded to 1 mm (GEOJSON_HEIGHT_DECIMALS).
ATOL_EXPORT_H_M = 0.5e-3


@pytest.fixture(scope="module")
def networks(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("heights")
    return {h: load_network(write_geojson(tmp / f"{h}.geojson", heights=h))
            for h in (True, False)}


def test_geojson_with_heights_fits_them(networks):
    """[lon, lat, h] on every point: the network has heights and the fitted track follows
    the closed-form heights within the vertical fit's aim (DEFAULT_VTOL_M; 0.14 m
    measured)."""
    net = networks[True]
    assert net.heights
    track = net.elements[ELEMENT]
    s = np.linspace(0.0, track.length_m, 400)
    _, _, h = track.geodetic(s)
    assert np.max(np.abs(h - height_m(s))) < DEFAULT_VTOL_M


def test_geojson_without_heights_has_none(networks):
    net = networks[False]
    assert not net.heights
    _, _, h = net.elements[ELEMENT].geodetic(np.linspace(0.0, 1000.0, 5))
    np.testing.assert_array_equal(h, 0.0)        # the placeholder, flagged above


def _two_elements(tmp_path, forms) -> Path:
    """Two netelements 1 km apart; `forms`: their coordinates' lengths."""
    features = []
    for k, dims in enumerate(forms):
        coords = [[4.0 + 0.01 * k, 50.0, 100.0][:dims], [4.0 + 0.01 * k, 50.001, 101.0][:dims]]
        features.append({"type": "Feature", "properties": {"id": f"e{k}"},
                         "geometry": {"type": "LineString", "coordinates": coords}})
    path = tmp_path / "two.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    return path


def test_some_netelements_with_heights_give_a_network_without_and_a_warning(tmp_path,
                                                                              caplog):
    with caplog.at_level(logging.WARNING, logger="trackmodel.network_folder"):
        source = read_network_geojson(_two_elements(tmp_path, (3, 2)))
    assert source.heights is None
    assert "1 of 2 netelements have heights" in caplog.text
    assert read_network_geojson(_two_elements(tmp_path, (3, 3))).heights is not None


def test_a_netelement_mixing_both_forms_is_an_error(tmp_path):
    feature = {"type": "Feature", "properties": {"id": "m"}, "geometry": {
        "type": "LineString", "coordinates": [[4.0, 50.0, 100.0], [4.0, 50.001]]}}
    path = tmp_path / "mixed.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [feature]}))
    with pytest.raises(TrackFileError, match=r"all \[lon, lat\] or all \[lon, lat, h\]"):
        read_network_geojson(path)


@pytest.mark.parametrize("heights", [True, False])
def test_folder_keeps_whether_it_has_heights(networks, tmp_path, heights):
    write_network(networks[heights], tmp_path / "net")
    index = pd.read_csv(tmp_path / "net" / "elements.csv", dtype=str)
    assert (HEIGHTS_COLUMN in index) == (not heights)     # absent: a track file has heights
    assert read_network(tmp_path / "net").heights == heights


def test_folder_heights_cell_is_checked(networks, tmp_path):
    write_network(networks[False], tmp_path / "net")
    index = tmp_path / "net" / "elements.csv"
    index.write_text(index.read_text().replace(",no", ",maybe"))
    with pytest.raises(TrackFileError, match="row 1, heights: heights must be yes, no or "
                                             "empty, got 'maybe'"):
        read_network(tmp_path / "net")


@pytest.mark.parametrize("heights", [True, False])
def test_geojson_export_writes_heights_only_when_known(networks, tmp_path, heights):
    net = networks[heights]
    write_network_geojson(net, tmp_path / "out.geojson")
    coords = np.array(json.loads((tmp_path / "out.geojson").read_text())
                      ["features"][0]["geometry"]["coordinates"])
    assert coords.shape[1] == (3 if heights else 2)
    back = load_network(tmp_path / "out.geojson")
    assert back.heights == heights
    if heights:
        track = net.elements[ELEMENT]
        s = np.linspace(0.0, track.length_m, coords.shape[0])   # the export's own spacing
        np.testing.assert_allclose(coords[:, 2], track.geodetic(s)[2], atol=ATOL_EXPORT_H_M)


def test_shipped_sources_say_whether_they_have_heights():
    """The Brussels source is 2-D (tp-lib's file: [lon, lat] pairs, see its excerpt), OSM
    has no heights, a track file has them."""
    excerpt = json.loads((DATA / "networks" / "brussels_switch.geojson").read_text())
    assert all(len(p) == 2 for f in excerpt["features"] if f["geometry"]["type"] == "LineString"
               for p in f["geometry"]["coordinates"])
    assert not read_network_geojson(DATA / "networks" / "brussels_switch.geojson").heights
    assert not read_network(DATA / "networks" / "brussels_airport").heights
    assert not load_network(DATA / "networks" / "osm" / "handmade.osm").heights
    assert load_network(DATA / "tracks" / "curvy.csv").heights


def test_network_defaults_to_heights(networks):
    net = networks[True]
    assert Network(net.elements, []).heights
