"""Route lines (`trackmodel.network_lines`): joint transitions, shared prefixes, the map
from the line back to the netelements.

References: a synthetic switch of straight sections (closed-form positions and angles),
and the real Brussels network (data/networks/brussels_airport), whose routes through one
switch must coincide on their common legs.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tests.support.networks import DIVERGE_RAD, straight, switch_tracks
from trackmodel.errors import TrackError
from trackmodel.network import END, START, Connection, NetPosition, Network
from trackmodel.network_io import read_network
from trackmodel.network_lines import (
    ROUTE_MIN_RADIUS_M,
    ROUTE_REFIT_TOL_M,
    tail_sections,
)
from trackmodel.sections import Section
from trackmodel.track import Track

NETWORKS = Path(__file__).resolve().parents[2] / "data" / "networks"
ATOL_M = 1e-3


@pytest.fixture(scope="module")
def switch() -> Network:
    """T (1000 m north) -> S (500 m north) or D (500 m at 0.1 rad)."""
    tracks = switch_tracks()
    return Network({k: tracks[k] for k in "TSD"},
                   [Connection("T", END, "S", START), Connection("T", END, "D", START),
                    Connection("S", START, "D", START, "none")])


def test_routes_share_their_common_leg_exactly(switch):
    ahead = switch.route_line((("T", 1), ("S", 1))).track
    diverging = switch.route_line((("T", 1), ("D", 1))).track
    s = np.linspace(0.0, 1000.0, 2001)
    assert np.array_equal(ahead.at(s).r_e, diverging.at(s).r_e)        # the same floats
    assert np.array_equal(ahead.at(s).r_e, switch.elements["T"].at(s).r_e)
    # the straight-through joint is continuous: the line is T then S
    on_s = switch.elements["S"].at(np.array([250.0])).r_e
    assert np.linalg.norm(ahead.at(np.array([1250.0])).r_e - on_s) < ATOL_M


def test_transition_lands_on_the_branch(switch):
    """After the transition the line runs on D; within it, it stays within the tolerance
    of D's line, turns at no radius below the minimum, and has no instant turn."""
    route = switch.route_line((("T", 1), ("D", 1)))
    line_l, leg_l = route.transitions[1]
    assert 0.0 < leg_l <= 100.0 and line_l == pytest.approx(leg_l, abs=0.05)
    d = switch.elements["D"]
    beyond = np.linspace(1000.0 + line_l, route.track.length_m, 50)
    on_d = d.at(beyond - 1000.0 - line_l + leg_l)
    assert np.max(np.linalg.norm(route.track.at(beyond).r_e - on_d.r_e, axis=1)) < ATOL_M
    inside = np.linspace(1000.0, 1000.0 + line_l, 200)
    lat, lon, _ = route.track.geodetic(inside)
    assert np.max(np.abs(d.project(lat, lon).cross_track_m)) <= ROUTE_REFIT_TOL_M + 1e-6
    curvature = np.abs(route.track.at(inside).curvature_1pm)
    assert 1.0 / curvature.max() >= ROUTE_MIN_RADIUS_M
    heading = np.unwrap(route.track.at(np.arange(990.0, 1000.0 + line_l + 10.0, 0.25)).azimuth)
    assert np.max(np.abs(np.diff(heading))) < 0.25 * curvature.max() + 1e-9
    assert heading[-1] - heading[0] == pytest.approx(DIVERGE_RAD, abs=1e-6)


def test_element_at_maps_the_line_back(switch):
    route = switch.route_line((("T", 1), ("D", 1)))
    for s in (10.0, 999.0, 1001.0, 1030.0, 1300.0, route.track.length_m):
        element, offset, direction = route.element_at(s)
        there = switch.elements[element].at(np.array([offset])).r_e
        assert direction == 1
        assert np.linalg.norm(route.track.at(np.array([s])).r_e - there) <= ROUTE_REFIT_TOL_M
    assert route.element_at(500.0)[:2] == ("T", 500.0)
    back = switch.route_line((("D", -1), ("T", -1)))
    element, offset, direction = back.element_at(100.0)
    assert (element, direction) == ("D", -1) and offset == pytest.approx(400.0, abs=1e-9)


def test_tail_sections_cut_a_clothoid_exactly():
    track = Track.from_sections([Section(100.0, 30.0, 0.5, 0.0, 0.01, 1.0),
                                 Section(50.0, None, None, 0.01)],
                                lat=math.radians(50.0), lon=math.radians(4.0))
    start = track.at(np.array([40.0]))
    tail = Track.from_sections(tail_sections(track, 40.0), lat=float(start.lat[0]),
                               lon=float(start.lon[0]), h=float(start.h[0]))
    s = np.linspace(0.0, tail.length_m, 40)
    assert tail.length_m == pytest.approx(110.0, abs=1e-9)
    assert np.max(np.linalg.norm(tail.at(s).r_e - track.at(s + 40.0).r_e, axis=1)) < ATOL_M


def test_brussels_routes_agree_up_to_their_switch():
    """The routes ahead of 88_L_111:1000:- part at switches; each pair is the same line
    (the same floats) up to the end of their last common leg."""
    net = read_network(NETWORKS / "brussels_airport")
    routes = net.routes_ahead(NetPosition("88_L_111", 1000.0, -1), horizon_m=2500.0)
    lines = [net.route_line(r.legs) for r in routes]
    assert len(lines) == 3
    for a in range(len(lines)):
        for b in range(a + 1, len(lines)):
            common = 0
            while routes[a].legs[common] == routes[b].legs[common]:
                common += 1
            shared = lines[a].starts_m[common]
            assert shared == lines[b].starts_m[common] and shared > 500.0
            s = np.linspace(0.0, shared, 500)
            assert np.array_equal(lines[a].track.at(s).r_e, lines[b].track.at(s).r_e)


def test_a_joint_no_transition_can_follow_is_named(switch):
    t = switch.elements["T"]
    back = straight(*t.geodetic(1000.0)[:2], 20.0, math.radians(120.0))
    net = Network({"T": t, "B": back}, [Connection("T", END, "B", START)])
    with pytest.raises(TrackError, match="joint T -> B: a kink of 120.0°"):
        net.route_line((("T", 1), ("B", 1)))
