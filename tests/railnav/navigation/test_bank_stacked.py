"""The inertial hypotheses of a bank propagated together
(`railnav.navigation.hypothesis_step.EngineStepper` with ``stacked``, `ekf.stacked`)
against the same bank stepped filter by filter through the engine: a line and its
parallels 4.5 m apart as a network without connections (`benchmarks/bench_speed.py`'s
bank, shorter), the same run to the bit."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from railnav.filters.protocol import make_filter
from railnav.jobs.network import candidate_starts
from railnav.jobs.tracks import track_nav, track_network
from railnav.navigation.network_navigator import navigate_network
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from trackmodel.io import read_track
from trackmodel.offset import offset_track

#: Tracks of the bank: the line and one parallel on each side.
SPACING_M = 4.5
TRIP_S = 20.0


@pytest.fixture(scope="module")
def bank_runs():
    base = read_track(TRACKS_DIR / "double_a.csv")
    tracks = [offset_track(base, -SPACING_M), base, offset_track(base, SPACING_M)]
    scenario = replace(get_scenario("curvy"), duration_s=TRIP_S, sigma_pseudorange_m=3.0)
    trip = simulate_trip(scenario, track=base, seed=1)
    config = navigator_config_for(scenario)
    network = track_network(tracks, ["left", "line", "right"])
    initial = candidate_starts(trip, config, make_filter(base, config, None))
    near = (float(trip.truth.lat[0]), float(trip.truth.lon[0]))
    nav = track_nav(len(tracks))

    def run(stacked: bool):
        return navigate_network(network, trip.sensor_data(), config,
                                nav=replace(nav, stacked=stacked), initial=initial, near=near)
    return run(True), run(False)


def test_stacked_bank_equals_the_bank_stepped_filter_by_filter(bank_runs):
    """Every cycle's netelement, probabilities and evidence, the most probable
    hypothesis's state and covariance, the logged hypotheses and innovations: equal."""
    stacked, one_by_one = bank_runs
    assert len(stacked.cycles) > TRIP_S                  # an epoch a second, and more
    pd.testing.assert_frame_equal(stacked.cycles, one_by_one.cycles, check_exact=True)
    np.testing.assert_array_equal(stacked.x, one_by_one.x)
    np.testing.assert_array_equal(stacked.P, one_by_one.P)
    assert stacked.element_probability == one_by_one.element_probability
    assert stacked.element_log_likelihood == one_by_one.element_log_likelihood
    pd.testing.assert_frame_equal(stacked.innovations, one_by_one.innovations,
                                  check_exact=True)
    columns = [c for c in stacked.hypotheses.columns if c not in ("id", "parent")]
    pd.testing.assert_frame_equal(stacked.hypotheses[columns],
                                  one_by_one.hypotheses[columns], check_exact=True)
    assert stacked.n_steps == one_by_one.n_steps


def test_the_bank_finds_the_line(bank_runs):
    """The trip runs on the middle track: after 20 s of 3-m pseudoranges it holds most of
    the probability (the bank works, stacked or not)."""
    stacked, _ = bank_runs
    final = stacked.element_probability[-1]
    assert max(final, key=final.get) == "line"
