"""Routes named by their netelements and networks from any file (`trackmodel.network_routes`).

References: a synthetic switch of straight sections (closed-form topology and lengths), the
shipped Brussels network's listed routes (`Network.routes_ahead`), and the files shipped in
data/ (each read by its own reader).
"""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.networks import switch_tracks
from trackmodel.errors import TrackError, TrackFileError
from trackmodel.network import END, START, Connection, NetPosition, Network
from trackmodel.network_io import read_network
from trackmodel.network_routes import (
    load_network,
    parse_route,
    route_legs,
    route_text,
    route_track,
)

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="module")
def switch() -> Network:
    """T (1000 m north) -> S (500 m north) or D (500 m at 0.1 rad); Y ends where S ends."""
    return Network(switch_tracks(),
                   [Connection("T", END, "S", START), Connection("T", END, "D", START),
                    Connection("S", START, "D", START, "none"), Connection("S", END, "Y", END)])


def test_parse_route():
    assert parse_route("A,-B>+C") == [("A", None), ("B", -1), ("C", 1)]
    for bad in ("", "A,,B", "A,-", " , "):
        with pytest.raises(TrackError, match="separated by"):
            parse_route(bad)


def test_directions_follow_the_connections(switch):
    assert route_legs(switch, "T,S,Y") == (("T", 1), ("S", 1), ("Y", -1))
    assert route_legs(switch, "Y,S,T") == (("Y", 1), ("S", -1), ("T", -1))
    assert route_legs(switch, "-D,T") == (("D", -1), ("T", -1))
    assert route_legs(switch, "D") == (("D", 1),)
    assert route_text(route_legs(switch, "Y,S,T")) == "Y>-S>-T"
    line = route_track(switch, "T,S,Y")
    assert line.length_m == pytest.approx(1800.0, abs=1e-3)      # continuous: no transition


@pytest.mark.parametrize("route, message", [
    ("T,Q", "no netelement 'Q'"),
    ("S,D", "no passage"),                 # the two branches do not pass
    ("T,-S", "no passage"),
    ("T,Y", "no passage"),
])
def test_bad_routes(switch, route, message):
    with pytest.raises(TrackError, match=message):
        route_legs(switch, route)


def test_brussels_route_as_listed():
    net = read_network(DATA / "networks" / "brussels_airport")
    routes = net.routes_ahead(NetPosition("88_L_111", 1000.0, -1), horizon_m=2500.0)
    for route in routes:
        assert route_legs(net, route_text(route.legs)) == route.legs
        names = ",".join(e for e, _ in route.legs)                 # unsigned: inferred
        assert route_legs(net, names) == route.legs


@pytest.mark.parametrize("path, n", [
    (DATA / "networks" / "brussels_switch.geojson", 3),
    (DATA / "networks" / "osm" / "handmade.osm", 8),
    (DATA / "networks" / "brussels_airport", 74),
    (DATA / "tracks" / "curvy.csv", 1),
])
def test_load_network_reads_every_kind(path, n):
    net = load_network(path)
    assert len(net.elements) == n
    if n == 1:
        assert list(net.elements) == ["curvy"]


def test_load_network_refuses_other_files(tmp_path):
    with pytest.raises(TrackFileError, match="not a network"):
        load_network(tmp_path / "x.txt")
