"""The accelerometer pseudo-observation through curves, transitions and grades (curvy.csv).

If the centripetal acceleration v²κ were missing (the 2017 paper's erratum 7) the lateral
residual would be ~0.8 m/s² against a per-sample σ of ~0.015 m/s² (tactical IMU at
100 Hz): NIS in the thousands. Reference: the χ² distribution with 2 degrees of freedom
(mean 2, standard deviation 2) and white noise (no lag correlation).
"""
from __future__ import annotations

import numpy as np
import pytest

from railnav.jobs.run import run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from trackmodel.io import read_track

#: Band half-width in standard errors of the mean (stored NIS are 0.1 s apart; their
#: correlation is checked separately below).
SIGMAS = 4.0


@pytest.fixture(scope="module")
def curvy_run():
    track = read_track(TRACKS_DIR / "curvy.csv")
    return track, run_simulated(track, get_scenario("curvy"), seed=3)


def _segment_kind(track, s):
    point = track.at(np.clip(s, 0.0, track.length_m))
    table, sec = track.table, point.section
    return np.where(table.curvature0[sec] != table.curvature1[sec], "transition",
                    np.where(table.curvature0[sec] != 0.0, "arc", "straight"))


def test_pseudo_observation_nis_is_chi2_on_every_kind_of_section(curvy_run):
    track, out = curvy_run
    raw = out.result.raw
    s = np.interp(raw.t_c, out.truth.time_s, out.truth.s)
    moving = np.interp(raw.t_c, out.truth.time_s, out.truth.v) > 1.0
    kind = _segment_kind(track, s)
    for name in ("straight", "arc", "transition"):
        nis = raw.nis_c[moving & (kind == name)]
        assert nis.size > 100, name   # the trip does run through each kind
        assert abs(nis.mean() - 2.0) < SIGMAS * 2.0 / np.sqrt(nis.size), name


def test_pseudo_observation_innovations_are_white(curvy_run):
    _, out = curvy_run
    innov = out.result.raw.innov_c
    for j in range(innov.shape[1]):
        x = innov[:, j] - innov[:, j].mean()
        lag1 = np.dot(x[:-1], x[1:]) / np.dot(x, x)
        assert abs(lag1) < SIGMAS / np.sqrt(x.size)
