"""Which way did the train go? Routes through the real Brussels network (issue 13).

References: the true route must win after the switch (the diverging branch is 94 m away
at the horizon), and before it the bank must never be confidently wrong: each route line
is refitted on its own (the switch's kink made a short curve), so the lines of two routes
agree before the switch within the refit's tolerance (measured: 0.15 m), and the true
route's probability may rise there but must not fall far below its prior 1/2.
Geometry: data/networks/brussels_airport (tp-lib's test data).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from railnav.jobs.network import route_candidates, run_simulated_network
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import get_scenario
from trackmodel.network import NetPosition
from trackmodel.network_io import read_network

NETWORK = Path(__file__).resolve().parents[3] / "data" / "networks" / "brussels_airport"
#: Two routes: 88_L_111 travelled backwards, then a switch (88_L_154 or the other way).
ELEMENT, BACK_FROM_END_M = "88_L_111", 50.0
SPEED_MPS, DURATION_S = 20.0, 100.0


@pytest.fixture(scope="module")
def network():
    return read_network(NETWORK)


@pytest.fixture(scope="module")
def start(network):
    return NetPosition(ELEMENT, network.length_m(ELEMENT) - BACK_FROM_END_M, -1)


def _divergence_s(tracks, start_s) -> float:
    """First distance along the routes where the two lines are > 1 m apart."""
    s = np.arange(start_s, min(t.length_m for t in tracks), 1.0)
    gap = np.linalg.norm(tracks[0].at(s).r_e - tracks[1].at(s).r_e, axis=1)
    return float(s[np.argmax(gap > 1.0)])


#: Two route lines refitted within 0.5 m of one chained line agree within twice that.
REFIT_TOL_M = 0.5


def test_two_routes_share_their_start(network, start):
    names, tracks, start_s = route_candidates(network, start, horizon_m=2500.0)
    assert len(names) == 2 and all(n.startswith(f"-{ELEMENT}>") for n in names)
    assert start_s == pytest.approx(BACK_FROM_END_M)
    s = np.arange(start_s, _divergence_s(tracks, start_s) - 100.0, 5.0)
    gap = np.linalg.norm(tracks[0].at(s).r_e - tracks[1].at(s).r_e, axis=1)
    assert gap.max() < 2 * REFIT_TOL_M


@pytest.mark.parametrize("true_route", [0, 1])
def test_the_route_taken_is_identified(network, start, true_route):
    names, tracks, start_s = route_candidates(network, start, horizon_m=2500.0)
    split_s = _divergence_s(tracks, start_s)
    scenario = replace(get_scenario("curvy"), profile=constant_speed(SPEED_MPS),
                       duration_s=DURATION_S, outages=())
    run = run_simulated_network(network, start, scenario, true_route=true_route,
                                horizon_m=2500.0, seed=4)
    bank = run.bank
    assert bank.names == names
    t_split = (split_s - start_s) / SPEED_MPS
    before = bank.time_s < t_split - 5.0
    assert before.sum() > 10
    assert bank.probabilities[before, true_route].min() > 0.2     # never confidently wrong
    final = bank.final_probabilities()
    assert final[names[true_route]] > 0.99, final
