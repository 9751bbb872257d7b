"""Fitting: a known track sampled, noised, thinned and refitted; the real survey in data/."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trackmodel.earth import C_n_e, ecef_to_geodetic
from trackmodel.errors import TrackError
from trackmodel.fit import fit_track
from trackmodel.io import read_track
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

TRACKS = Path(__file__).resolve().parents[2] / "data" / "tracks"
TOL_M = 0.5                  # the default tolerance
NOISE_M = 0.1                # σ of the survey noise (issue)
ATOL_KINK = 1e-9             # tangent continuity at joints: rounding of the azimuth sum
#: A refit of noisy points can differ from the truth by the tolerance plus the noise.
ATOL_TRUTH_M = TOL_M + 4 * NOISE_M

TRUTH = Track([Section(800.0, 60.0, 0.0), Section(100.0, None, None, 0.0, 1 / 600),
               Section(400.0, None, None, 1 / 600), Section(100.0, None, None, 1 / 600, 0.0),
               Section(900.0, None, None), Section(80.0, None, None, 0.0, -1 / 900),
               Section(300.0, None, None, -1 / 900), Section(80.0, None, None, -1 / 900, 0.0),
               Section(500.0, None, None)], Origin(48.0, 11.0, 0.0))


def survey(rng, n=350):
    s = np.sort(rng.uniform(0.0, TRUTH.length_m, n))
    s[0], s[-1] = 0.0, TRUTH.length_m
    s = np.concatenate([s, s[100:110]])                     # repeated points
    s.sort()
    pt = TRUTH.at(s)
    d_n = np.column_stack([rng.normal(0.0, NOISE_M, (len(s), 2)), np.zeros(len(s))])
    lat, lon, _ = ecef_to_geodetic(pt.r_e + np.einsum("...ij,...j->...i",
                                                      C_n_e(pt.lat, pt.lon), d_n))
    return lat, lon


@pytest.fixture(scope="module")
def refit():
    rng = np.random.default_rng(20171103)
    lat, lon = survey(rng)
    return fit_track(lat, lon, tol_m=TOL_M), lat, lon


def test_refit_within_tolerance_of_every_point(refit):
    result, lat, lon = refit
    proj = result.track.project(lat, lon)                  # independent re-check
    assert np.hypot(proj.cross_track_m, proj.along_m).max() <= TOL_M
    assert result.max_horizontal_m <= TOL_M


def test_refit_is_tangent_continuous(refit):
    track = refit[0].track
    joints = track.table.s_start[1:]
    before, after = track.at(joints - 1e-9), track.at(joints)
    assert np.abs(before.u_n - after.u_n).max() < ATOL_KINK
    assert all(sec.azimuth_deg is None for sec in track.sections[1:])


def test_refit_follows_the_true_track(refit):
    track = refit[0].track
    s = np.linspace(0.0, TRUTH.length_m, 200)
    pt = TRUTH.at(s)
    proj = track.project(pt.lat, pt.lon)
    assert np.abs(proj.cross_track_m).max() < ATOL_TRUTH_M
    assert abs(track.length_m - TRUTH.length_m) < 2.0     # ends pinned to the end points


def test_refit_has_few_sections(refit):
    # the truth has 9 sections; greedy knots may need some more, not one per point
    assert refit[0].n_sections <= 30


def test_without_heights_track_is_flat(refit):
    track = refit[0].track
    assert track.origin.h_m == 0.0 and np.all(track.table.elevation0 == 0.0)


def test_real_survey_within_tolerance_of_shipped_track():
    survey = pd.read_csv(TRACKS / "barcelona_drive_survey.csv")
    track = read_track(TRACKS / "barcelona_drive.csv")
    proj = track.project(np.radians(survey.lat_deg), np.radians(survey.lon_deg))
    assert np.hypot(proj.cross_track_m, proj.along_m).max() <= TOL_M


def test_reversed_direction_is_reported():
    s = np.concatenate([np.linspace(0, 500, 60), np.linspace(495, 300, 30)])
    pt = TRUTH.at(s)
    with pytest.raises(TrackError, match="reverses its direction"):
        fit_track(pt.lat, pt.lon)


def test_stationary_survey_is_rejected():
    with pytest.raises(TrackError, match="nothing to fit"):
        fit_track(np.radians([48.0, 48.0, 48.0]), np.radians([11.0, 11.0, 11.0]))
