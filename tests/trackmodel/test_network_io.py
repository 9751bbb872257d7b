"""Network files (issue 13): GeoJSON export read back, the network folder's attributes and
atomic writing, a track file as a one-element network.

References: a synthetic switch of straight sections (closed-form lengths), the Brussels
switch excerpt (tp-lib's data: its relations must survive the round trip), and the
fitted tracks themselves (the exported points lie on them).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.support.networks import switch_tracks
from trackmodel.errors import TrackError
from trackmodel.io import read_track
from trackmodel.network import END, START, Connection, Network
from trackmodel.network_io import (
    GEOJSON_STEP_M,
    build_network,
    network_from_track,
    read_network,
    read_network_geojson,
    write_network,
    write_network_geojson,
)

DATA = Path(__file__).resolve().parents[2] / "data"
FIT_TOL_M = 0.5


@pytest.fixture(scope="module")
def switch() -> Network:
    tracks = switch_tracks()
    return Network({k: tracks[k] for k in "TSD"},
                   [Connection("T", END, "S", START), Connection("T", END, "D", START, "AB"),
                    Connection("S", START, "D", START, "none")],
                   {"T": {"gauge": "1435", "usage": "main"}, "D": {"service": "siding"}})


def _topology(net: Network) -> set:
    """The connections, each written from its smaller end (AB and BA swap with it)."""
    out = set()
    for c in net.connections:
        if (c.a, c.a_end) <= (c.b, c.b_end):
            out.add((c.a, c.a_end, c.b, c.b_end, c.navigability))
        else:
            flipped = {"AB": "BA", "BA": "AB"}.get(c.navigability, c.navigability)
            out.add((c.b, c.b_end, c.a, c.a_end, flipped))
    return out


def test_geojson_round_trip(switch, tmp_path):
    path = tmp_path / "net.geojson"
    write_network_geojson(switch, path)
    source = read_network_geojson(path)
    again = build_network(source)
    assert _topology(again) == _topology(switch)
    assert again.attributes == switch.attributes
    for name, track in switch.elements.items():
        assert again.length_m(name) == pytest.approx(track.length_m, abs=1e-2)
        lat, lon = source.polylines[name]
        assert len(lat) == math.ceil(track.length_m / GEOJSON_STEP_M) + 1
        assert np.max(np.abs(track.project(lat, lon).cross_track_m)) < 1e-3
    features = json.loads(path.read_text())["features"]
    relation = next(f for f in features if f["properties"].get("type") == "netrelation")
    assert set(relation["properties"]) >= {"netelementA", "positionOnA", "netelementB",
                                           "positionOnB", "navigability"}


def test_real_excerpt_round_trip(tmp_path):
    """The Brussels switch excerpt: relations kept, and the refit of the exported points
    within the fit tolerance of the first fit."""
    first = build_network(read_network_geojson(DATA / "networks" / "brussels_switch.geojson"))
    write_network_geojson(first, tmp_path / "x.geojson")
    again = build_network(read_network_geojson(tmp_path / "x.geojson"))
    assert _topology(again) == _topology(first)
    for name, track in first.elements.items():
        lat, lon, _ = track.geodetic(np.linspace(0.0, track.length_m, 200))
        assert np.max(np.abs(again.elements[name].project(lat, lon).cross_track_m)) <= (
            FIT_TOL_M + 0.01)


def test_folder_keeps_attributes_and_replaces_atomically(switch, tmp_path):
    out = tmp_path / "net"
    write_network(switch, out)
    again = read_network(out)
    assert again.attributes == switch.attributes and _topology(again) == _topology(switch)
    single = network_from_track(switch.elements["T"], "T")
    write_network(single, out)                          # an existing network folder
    assert sorted(read_network(out).elements) == ["T"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["net"]      # no leftovers
    (tmp_path / "file").write_text("x")
    with pytest.raises(TrackError, match="not a network folder"):
        write_network(single, tmp_path / "file")
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "keep.txt").write_text("x")
    with pytest.raises(TrackError, match="not a network folder"):
        write_network(single, tmp_path / "other")


def test_track_file_as_a_one_element_network():
    track = read_track(DATA / "tracks" / "curvy.csv")
    net = network_from_track(track, "curvy")
    assert list(net.elements) == ["curvy"] and net.connections == ()
    assert net.successors("curvy", 1) == [] and net.length_m("curvy") == track.length_m
    line = net.route_track((("curvy", 1),))
    s = np.linspace(0.0, track.length_m, 100)
    assert np.array_equal(line.at(s).r_e, track.at(s).r_e)
