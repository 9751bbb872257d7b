"""Track networks (issue 13): successors, routes and distances, projection, kinks, files.

References: a synthetic switch built from straight sections whose distances and angles are
known in closed form (sums of section lengths, the diverging azimuth), and the real
Brussels network (tp-lib's test data, data/networks/brussels_airport), whose file gives
the connections that a fitted network must keep.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from trackmodel.errors import TrackError, TrackFileError
from trackmodel.io import read_track
from trackmodel.network import (
    END,
    START,
    Connection,
    NetPosition,
    Network,
    reversed_track,
)
from trackmodel.network_io import (
    build_network,
    read_network,
    read_network_geojson,
    write_network,
)
from trackmodel.sections import Section
from trackmodel.track import Track

#: Distances are sums of straight sections on WGS-84: exact up to the end-point joins of
#: separately built tracks (< 1 mm here).
ATOL_M = 1e-3
DIVERGE_RAD = 0.1           # the diverging branch's azimuth, rad (a 1:10 switch)


def _straight(lat, lon, length_m, azimuth_rad):
    return Track.from_sections([Section(length_m, math.degrees(azimuth_rad))],
                               lat=float(np.squeeze(lat)), lon=float(np.squeeze(lon)))


@pytest.fixture(scope="module")
def switch() -> Network:
    """X (800 m north) -> T (1000 m north) -> S (500 m north) or D (500 m at 0.1 rad);
    Y runs 300 m south and ends where S ends (so it is entered at its END)."""
    x = _straight(math.radians(50.0), math.radians(4.0), 800.0, 0.0)
    t = _straight(*x.geodetic(800.0)[:2], 1000.0, 0.0)
    s = _straight(*t.geodetic(1000.0)[:2], 500.0, 0.0)
    d = _straight(*t.geodetic(1000.0)[:2], 500.0, DIVERGE_RAD)
    north = s.geodetic(500.0)
    y_start = _straight(*north[:2], 300.0, 0.0).geodetic(300.0)
    y = _straight(*y_start[:2], 300.0, math.pi)
    connections = [Connection("X", END, "T", START), Connection("T", END, "S", START),
                   Connection("T", END, "D", START), Connection("S", START, "D", START, "none"),
                   Connection("S", END, "Y", END)]
    return Network({"X": x, "T": t, "S": s, "D": d, "Y": y}, connections)


def test_successors_follow_ends_and_navigability(switch):
    assert switch.successors("T", 1) == [("D", 1), ("S", 1)]
    assert switch.successors("S", 1) == [("Y", -1)]          # Y is entered at its end
    assert switch.successors("S", -1) == [("T", -1)]         # not D: the branches do not pass
    assert switch.successors("Y", -1) == []                  # Y's start is a buffer stop
    assert switch.successors("Y", 1) == [("S", -1)]
    assert switch.predecessors("T", 1) == [("X", 1)]
    assert sorted(switch.predecessors("T", -1)) == [("D", -1), ("S", -1)]


def test_distances_are_sums_of_lengths(switch):
    start = NetPosition("X", 100.0, 1)
    # 700 m left on X, T 1000, S 500, then Y entered at s = 300 travelling to s = 100
    assert switch.distance_m(start, NetPosition("Y", 100.0)) == pytest.approx(2400.0, abs=ATOL_M)
    assert switch.distance_m(start, NetPosition("D", 200.0)) == pytest.approx(1900.0, abs=ATOL_M)
    assert switch.distance_m(NetPosition("T", 500.0), NetPosition("T", 800.0)) == 300.0
    # behind the direction of travel, and across the branches: no route
    assert switch.distance_m(NetPosition("T", 500.0), NetPosition("X", 100.0)) == math.inf
    assert switch.distance_m(NetPosition("S", 100.0, -1), NetPosition("D", 100.0)) == math.inf
    back = switch.distance_m(NetPosition("D", 100.0, -1), NetPosition("X", 700.0))
    assert back == pytest.approx(100.0 + 1000.0 + 100.0, abs=ATOL_M)


def test_routes_are_listed_shortest_first(switch):
    routes = switch.routes(NetPosition("X", 0.0), NetPosition("Y", 0.0), max_routes=3)
    assert len(routes) == 1
    assert routes[0].legs == (("X", 1), ("T", 1), ("S", 1), ("Y", -1))
    assert routes[0].length_m == pytest.approx(800 + 1000 + 500 + 300, abs=ATOL_M)


def test_kinks_are_the_switch_angles(switch):
    kinks = switch.kinks().set_index(["a", "b"])
    assert kinks.loc[("T", "D"), "kink_deg"] == pytest.approx(math.degrees(DIVERGE_RAD),
                                                               abs=1e-6)
    for pair in (("X", "T"), ("T", "S"), ("S", "Y")):
        assert kinks.loc[pair, "kink_deg"] < 1e-6 and kinks.loc[pair, "continuous"]
        assert kinks.loc[pair, "gap_m"] < ATOL_M
    assert ("S", "D") not in kinks.index                     # not navigable: not a joint


def test_projection_lists_the_candidates_within_the_radius(switch):
    # 3 m east of S at 250 m beyond the switch; D is 250 sin(0.1) = 25 m further east
    lat, lon, _ = switch.elements["S"].geodetic(250.0)
    lon_east = lon + 3.0 / (6_378_137.0 * math.cos(lat[0]))
    near = switch.project(lat, lon_east, radius_m=10.0)
    assert list(near["element"]) == ["S"]
    assert near["s_m"].iloc[0] == pytest.approx(250.0, abs=0.05)
    assert near["distance_m"].iloc[0] == pytest.approx(3.0, abs=0.05)
    wide = switch.project(lat, lon_east, radius_m=30.0)
    assert list(wide["element"]) == ["S", "D"]
    expected = 250.0 * math.sin(DIVERGE_RAD) - 3.0 * math.cos(DIVERGE_RAD)
    assert wide["distance_m"].iloc[1] == pytest.approx(expected, abs=0.3)


def test_bad_connections_are_errors(switch):
    with pytest.raises(TrackError, match="no netelement 'Q'"):
        Network(switch.elements, [Connection("T", END, "Q", START)])
    with pytest.raises(TrackError, match="navigability"):
        Network(switch.elements, [Connection("T", END, "S", START, "sometimes")])


def test_network_folder_round_trip(switch, tmp_path):
    write_network(switch, tmp_path / "net")
    again = read_network(tmp_path / "net")
    assert sorted(again.elements) == sorted(switch.elements)
    assert again.successors("T", 1) == switch.successors("T", 1)
    assert again.distance_m(NetPosition("X", 100.0), NetPosition("Y", 100.0)) == pytest.approx(
        2400.0, abs=ATOL_M)


def _geojson(features):
    return json.dumps({"type": "FeatureCollection", "features": features})


def _line(name, coords):
    return {"type": "Feature", "properties": {"id": name},
            "geometry": {"type": "LineString", "coordinates": coords}}


def _rel(a, pa, b, pb, nav="both"):
    return {"type": "Feature", "properties": {"netelementA": a, "positionOnA": pa,
                                              "netelementB": b, "positionOnB": pb,
                                              "navigability": nav},
            "geometry": {"type": "Point", "coordinates": [4.0, 50.0]}}


def test_geojson_reader_and_a_duplicate_relation(tmp_path, caplog):
    """A pair of ends given twice keeps the more restrictive navigability (as the shipped
    Brussels file needs for 88_L_262-88_L_11886)."""
    path = tmp_path / "n.geojson"
    lines = [_line("A", [[4.0, 50.0], [4.0, 50.01]]), _line("B", [[4.0, 50.01], [4.0, 50.02]])]
    path.write_text(_geojson(lines + [_rel("A", 1, "B", 0), _rel("B", 0, "A", 1, "none")]))
    source = read_network_geojson(path)
    assert set(source.polylines) == {"A", "B"}
    assert [c.navigability for c in source.connections] == ["none"]
    assert "given twice" in caplog.text
    net = build_network(source)
    assert net.length_m("A") == pytest.approx(1112.0, rel=2e-3)     # 0.01° of latitude
    assert net.successors("A", 1) == []


@pytest.mark.parametrize("features, message", [
    ([_line("A", [[4.0, 50.0]])], "need >= 2 finite points"),
    ([_line("A", [[400.0, 50.0], [4.0, 50.1]])], "lon must be in"),
    ([_line("A", [[4.0, 50.0], [4.0, 50.1]]), _rel("A", 1, "Z", 0)], "'Z'"),
    ([_line("A", [[4.0, 50.0], [4.0, 50.1]]), _rel("A", 2, "A", 0)], "0 or 1"),
    ([], "no LineString netelement"),
])
def test_bad_geojson_is_a_located_error(tmp_path, features, message):
    path = tmp_path / "bad.geojson"
    path.write_text(_geojson(features))
    with pytest.raises(TrackFileError, match=message) as info:
        read_network_geojson(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_not_json_is_a_located_error(tmp_path):
    path = tmp_path / "bad.geojson"
    path.write_bytes(b"\xff\xfe not json")
    with pytest.raises(TrackFileError, match="not a readable GeoJSON"):
        read_network_geojson(path)


# --- the real Brussels network (data/networks; provenance in its README) -----------------

NETWORKS = Path(__file__).resolve().parents[2] / "data" / "networks"
#: The fit's tolerance, m: every source point lies within it of its fitted netelement.
FIT_TOL_M = 0.5


@pytest.fixture(scope="module")
def real_switch():
    source = read_network_geojson(NETWORKS / "brussels_switch.geojson")
    return source, build_network(source)


def test_real_switch_keeps_the_file_topology(real_switch):
    """The file: 88_L_9755's start joins 88_L_2014's end and 88_L_11801's end (both
    navigable); the two branch ends touch but do not pass ('none')."""
    _, net = real_switch
    assert net.successors("88_L_9755", -1) == [("88_L_11801", -1), ("88_L_2014", -1)]
    assert net.successors("88_L_2014", 1) == [("88_L_9755", 1)]
    assert ("88_L_11801", -1) not in net.successors("88_L_2014", 1)
    kinks = net.kinks()
    assert len(kinks) == 2 and (kinks["gap_m"] < 1.0).all()


def test_real_points_lie_on_their_fitted_netelement(real_switch):
    source, net = real_switch
    for name, (lat, lon) in source.polylines.items():
        near = net.project(lat, lon, radius_m=5.0)
        own = near[near["element"] == name]
        assert own["point"].nunique() == lat.size, name       # every point found on its own
        assert own["distance_m"].max() <= FIT_TOL_M + 1e-3, name


def test_shipped_network_reads_and_routes(real_switch):
    """The shipped fitted network holds the excerpt's switch with the same successors, and
    the route through the switch is the sum of the fitted lengths."""
    net = read_network(NETWORKS / "brussels_airport")
    assert len(net.elements) == 74
    _, small = real_switch
    assert net.successors("88_L_9755", -1) == small.successors("88_L_9755", -1)
    start = NetPosition("88_L_9755", 10.0, -1)
    end = NetPosition("88_L_2014", 20.0)
    expected = 10.0 + net.length_m("88_L_2014") - 20.0
    assert net.distance_m(start, end) == pytest.approx(expected, abs=ATOL_M)


TRACKS = Path(__file__).resolve().parents[2] / "data" / "tracks"


@pytest.mark.parametrize("name", ["curvy.csv", "paper2017.csv", "barcelona_drive.csv"])
def test_reversed_track_runs_back_over_the_same_points(name):
    """Reference: the original track at L - s (arcs, clothoids, vertical curves, the
    paper's loxodrome with its exponential height law, a fitted real survey)."""
    track = read_track(TRACKS / name)
    back = reversed_track(track)
    assert back.length_m == pytest.approx(track.length_m, abs=1e-9)
    s = np.linspace(0.0, track.length_m, 257)
    there, here = track.at(track.length_m - s), back.at(s)
    assert np.max(np.linalg.norm(there.r_e - here.r_e, axis=1)) < ATOL_M
    turn = np.angle(np.exp(1j * (here.azimuth - there.azimuth - math.pi)))
    assert np.max(np.abs(turn)) < 1e-6


def test_route_track_chains_the_legs(switch):
    legs = (("X", 1), ("T", 1), ("S", 1), ("Y", -1))
    line = switch.route_track(legs, refit_tol_m=None)
    assert line.length_m == pytest.approx(2600.0, abs=ATOL_M)
    on_y = switch.elements["Y"].at(200.0)            # 100 m into Y, entered at its end
    assert np.linalg.norm(line.at(2400.0).r_e - on_y.r_e) < ATOL_M
    on_s = switch.elements["S"].at(250.0)
    assert np.linalg.norm(line.at(2050.0).r_e - on_s.r_e) < ATOL_M
    with pytest.raises(TrackError, match="no passage from S to D"):
        switch.route_track((("S", 1), ("D", 1)))


def test_route_track_refit_smooths_the_switch_kink(switch):
    """Through the diverging branch the chained line turns 0.1 rad at once; the route line
    (a joint transition on D, `trackmodel.network_lines`) stays within its tolerance of
    both legs and turns over tens of metres."""
    legs = (("T", 1), ("D", 1))
    with pytest.raises(TrackError, match="joint"):         # 5.7°: beyond the track model's
        switch.route_track(legs, refit_tol_m=None)         # limit on an instant turn
    line = switch.route_track(legs)
    for name in ("T", "D"):
        track = switch.elements[name]
        lat, lon, _ = track.geodetic(np.linspace(0.0, track.length_m, 201))
        assert line.project(lat, lon).distance_m.max() < 0.5 + 1e-3
    step = np.abs(np.diff(np.unwrap(line.at(np.arange(0.0, line.length_m, 1.0)).azimuth)))
    assert step.max() < 0.1 / 2              # no instant turn: at most half of it per metre
    assert abs(line.length_m - 1500.0) < 1.0


def test_routes_ahead_branch_at_each_switch(switch):
    routes = switch.routes_ahead(NetPosition("X", 300.0), horizon_m=10_000.0)
    assert [r.legs for r in routes] == [
        (("X", 1), ("T", 1), ("D", 1)),
        (("X", 1), ("T", 1), ("S", 1), ("Y", -1))]
    assert [r.length_m for r in routes] == pytest.approx([500 + 1000 + 500,
                                                          500 + 1000 + 500 + 300])
    short = switch.routes_ahead(NetPosition("X", 300.0), horizon_m=400.0)
    assert [r.legs for r in short] == [(("X", 1),)]        # the horizon ends on X
    with pytest.raises(TrackError, match="more than 1 routes"):
        switch.routes_ahead(NetPosition("X", 300.0), horizon_m=10_000.0, max_routes=1)
