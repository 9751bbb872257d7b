"""Fuzzed network files (issue 13): whatever the bytes, the network readers return a network
or raise their own one-line `TrackFileError`, within the case time limit
(`tests.support.fuzz`).

Readers: GeoJSON netelements + netrelations (`read_network_geojson`, then fitted with
`load_network`), OpenStreetMap XML and PBF (`read_osm`), and the network folder
(`read_network`: its index, its connections and an element's track file). Generators:
mutations of the shipped files (data/networks) and GeoJSON written from scratch (any
property types, coordinates with NaN, infinities and huge numbers, any positions and
navigabilities).
"""
from __future__ import annotations

import json
import logging
import tempfile
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import DATA
from tests.support.fuzz import FUZZ, mutated, time_limit
from trackmodel.errors import TrackFileError
from trackmodel.network_io import read_network, read_network_geojson, write_network
from trackmodel.network_routes import load_network
from trackmodel.osm import read_osm

NETWORKS = DATA / "networks"
GEOJSON = (NETWORKS / "brussels_switch.geojson").read_bytes()
OSM_FILES = {".osm": (NETWORKS / "osm" / "handmade.osm").read_bytes(),
             ".osm.pbf": (NETWORKS / "osm" / "pyrosm_test_rail.osm.pbf").read_bytes()}


def _our_error_only(read, data: bytes, name: str):
    """`read` of `data` written to a file: a result, or our one-line located error."""
    logging.disable(logging.WARNING)
    try:
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / name
            path.write_bytes(data)
            with time_limit():
                try:
                    return read(path)
                except TrackFileError as exc:
                    assert "\n" not in str(exc) and str(exc).startswith(str(path))
                    return None
    finally:
        logging.disable(logging.NOTSET)


@FUZZ
@given(mutated(GEOJSON))
def test_fuzz_mutated_geojson(data):
    network = _our_error_only(load_network, data, "n.geojson")
    if network is not None:
        assert len(network.elements) >= 1


def _feature(draw) -> dict:
    number = st.floats(allow_nan=True, allow_infinity=True) | st.integers(-10**20, 10**20)
    point = st.lists(number, min_size=0, max_size=4)
    if draw(st.booleans()):
        geometry = {"type": "LineString",
                    "coordinates": draw(st.lists(point, max_size=5) | st.just(
                        [[4.0, 50.0], [4.0, 50.001]]))}
        props = {"id": draw(st.sampled_from(["A", "B", "", 7, None]))}
    else:
        geometry = {"type": "Point", "coordinates": [4.0, 50.0]}
        props = {"netelementA": draw(st.sampled_from(["A", "B", "Z", 3, None])),
                 "netelementB": draw(st.sampled_from(["A", "B", [], "Z"])),
                 "positionOnA": draw(st.sampled_from([0, 1, 2, "1", True, 0.5, None, 1.0])),
                 "positionOnB": draw(st.sampled_from([0, 1, -1, "0", float("nan")])),
                 "navigability": draw(st.sampled_from(["both", "AB", "BA", "none", "x", 1]))}
    props.update(draw(st.dictionaries(st.sampled_from(["gauge", "usage", "type"]),
                                      st.text(max_size=3) | number, max_size=2)))
    return {"type": draw(st.sampled_from(["Feature", "feature"])),
            "properties": draw(st.just(props) | st.sampled_from([None, [], "x"])),
            "geometry": draw(st.just(geometry) | st.sampled_from([None, {}, {"type": 5}]))}


@st.composite
def geojson_texts(draw) -> bytes:
    features = [_feature(draw) for _ in range(draw(st.integers(0, 5)))]
    top = draw(st.sampled_from(["FeatureCollection", "Feature", None]))
    body = {"type": top, "features": draw(st.just(features) | st.sampled_from([None, {}, 3]))}
    return json.dumps(body, allow_nan=True).encode()


@FUZZ
@given(geojson_texts())
def test_fuzz_generated_geojson(data):
    _our_error_only(read_network_geojson, data, "n.geojson")


@FUZZ
@given(st.sampled_from(sorted(OSM_FILES)).flatmap(
    lambda suffix: st.tuples(st.just(suffix), mutated(OSM_FILES[suffix]))))
def test_fuzz_mutated_osm(case):
    suffix, data = case
    source = _our_error_only(read_osm, data, "x" + suffix)
    if source is not None:
        assert source.polylines


def _small_folder() -> dict[str, bytes]:
    """The files of the hand-made OSM network's folder (8 netelements), written once."""
    with tempfile.TemporaryDirectory() as folder:
        write_network(load_network(NETWORKS / "osm" / "handmade.osm"), Path(folder) / "net")
        root = Path(folder) / "net"
        return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*.csv")}


FOLDER = _small_folder()
#: The folder files fuzzed: its index, its connections and one netelement's track.
FOLDER_FILES = ("elements.csv", "connections.csv", "elements/w3.csv")


@FUZZ
@given(st.sampled_from(FOLDER_FILES).flatmap(lambda name: st.tuples(
    st.just(name), mutated(FOLDER[name]))))
def test_fuzz_mutated_network_folder(case):
    name, data = case
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder) / "net"
        for file, original in FOLDER.items():
            (root / file).parent.mkdir(parents=True, exist_ok=True)
            (root / file).write_bytes(data if file == name else original)
        with time_limit():
            try:
                read_network(root)
            except TrackFileError as exc:
                assert "\n" not in str(exc) and str(root) in str(exc)
