"""Geometry noise of the pseudo-observation (railnav/filters/geometry_noise.py).

References: closed forms for a curvature step (an arc or vertical curve without
transition) under a Gaussian prior — the unmodelled term is v²Δκ·1[s' > s_j], whose
variance is v⁴Δκ² p(1 − p) with p = Φ((s_ref − s_j)/σ) when the linear model carries no
slope there — and zero on straights, arcs and clothoids; plus the regression case of the
issue review: a navigation-grade outage on curvy.csv crossing a vertical curve's start.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import norm

from railnav.filters.geometry_noise import (
    _XI,
    MAX_OFFSET_M,
    STATISTICAL_MIN_SIGMA_M,
    _quadrature,
    statistical_parameters,
)
from railnav.filters.track_grid import TrackParameterGrid
from railnav.jobs.run import run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from strapdown.reduced import cross_track_basis
from trackmodel.io import read_track
from trackmodel.sections import Section
from trackmodel.track import Track

SPEED = 25.0
KAPPA = 1 / 2000     # 1/m
GRID_HALF_STEP_M = 0.25


def _step_tolerance(sigma):
    """Midpoint rule: a step's weight to within φ_max·Δξ/2 = 0.399·0.2/2; the grid moves
    the step by up to half a node spacing, φ_max·0.25/σ of probability."""
    return SPEED ** 4 * KAPPA ** 2 * (0.04 + 0.399 * GRID_HALF_STEP_M / sigma)


@pytest.fixture(scope="module")
def step_track():
    """A straight, then a 2000 m radius arc without transition (curvature step at 1000 m)."""
    return Track.from_sections([Section(1000.0, azimuth_deg=10.0),
                                Section(800.0, curvature_1pm=1 / 2000)],
                               lat=np.radians(47.0), lon=np.radians(8.0))


@pytest.mark.parametrize("s_ref, sigma", [(990.0, 5.0), (998.0, 3.0), (1003.0, 8.0),
                                          (1020.0, 6.0)])
def test_curvature_step_is_linearized_statistically(step_track, s_ref, sigma):
    """A curvature step Δκ at s_j under s' ~ N(s_ref, σ²): the mean of the lateral curvature
    is Δκ·p (p = P(s' > s_j)), the regression slope Δκ φ(z)/σ (Stein's lemma, z = (s_j −
    s_ref)/σ), and what the line leaves out has the variance Δκ²(p(1 − p) − φ(z)²)."""
    grid = TrackParameterGrid(step_track)
    params, _ = grid.parameters(np.array([s_ref]))
    node = params[0, 0]
    eff, var = statistical_parameters(grid, params, sigma_s_m=sigma, speed_mps=SPEED)
    lateral, _ = cross_track_basis(params[:, 7:10])
    arc, _ = grid.parameters(np.array([1400.0]))
    kappa_l = float(arc[0, 10:13] @ lateral[0])          # signed lateral curvature of the arc
    z = (1000.0 - node) / sigma
    p, phi = norm.sf(z), norm.pdf(z)
    tol_p = _step_tolerance(sigma) / (SPEED ** 4 * KAPPA ** 2)   # in probability units
    # the line is read at δ = 0, not at the nodes' mean offset (up to half a grid step):
    # slope × that offset, ≤ φ_max·0.25/σ in the same units
    tol_mean = tol_p + 0.399 * GRID_HALF_STEP_M / sigma
    assert eff[0, 10:13] @ lateral[0] == pytest.approx(kappa_l * p, abs=abs(kappa_l) * tol_mean)
    assert eff[0, 13:16] @ lateral[0] == pytest.approx(kappa_l * phi / sigma,
                                                       abs=abs(kappa_l) * tol_p / sigma)
    assert var[0, 0] == pytest.approx(SPEED ** 4 * KAPPA ** 2 * (p * (1 - p) - phi ** 2),
                                      abs=_step_tolerance(sigma))
    assert var[0, 1] < 1e-6 * max(var[0, 0], 1e-12)


def test_narrow_prior_keeps_the_local_expansion_and_its_bernoulli_remainder(step_track):
    """σ_s at most `STATISTICAL_MIN_SIGMA_M`: the parameters are the local ones and the
    remainder of a step is v⁴Δκ² P(other side) (the local model carries one side)."""
    grid = TrackParameterGrid(step_track)
    sigma = STATISTICAL_MIN_SIGMA_M
    params, _ = grid.parameters(np.array([999.0]))
    eff, var = statistical_parameters(grid, params, sigma_s_m=sigma, speed_mps=SPEED)
    assert eff is params
    p_other = norm.sf((1000.0 - params[0, 0]) / sigma)
    assert var[0, 0] == pytest.approx(SPEED ** 4 * KAPPA ** 2 * p_other,
                                      abs=_step_tolerance(sigma))


def test_no_geometry_noise_where_the_model_is_exact(step_track):
    """Inside the straight the remainder is zero; inside the arc it is the rotation of the
    curvature vector, |d³u/ds³| δ²/2 ≈ κ³(4σ)²/2, whose square times v⁴ bounds it (2.4e-6,
    against v⁴Δκ²/4 ≈ 0.02 at a step)."""
    grid = TrackParameterGrid(step_track)
    params, _ = grid.parameters(np.array([300.0, 1400.0]))   # straight, inside the arc
    sigma = 50.0
    _, var = statistical_parameters(grid, params, sigma_s_m=sigma, speed_mps=SPEED)
    assert np.all(var[0] < 1e-20)
    assert np.all(var[1] < SPEED ** 4 * (KAPPA ** 3 * (4 * sigma) ** 2 / 2) ** 2)
    params, _ = grid.parameters(np.array([995.0]))
    _, var = statistical_parameters(grid, params, sigma_s_m=0.2, speed_mps=SPEED)
    assert np.all(var < 1e-20)


@pytest.mark.parametrize("interval_m, fraction", [(1.0, 3.0 / 8.0), (0.0, 0.0)])
def test_a_sample_straddling_a_step_is_predicted_as_its_blend(step_track, interval_m,
                                                               fraction):
    """A sample is the mean over its interval: 0.125 m before the step with 1 m run per
    sample, 3/8 of its interval lies on the arc, so its centripetal term is 3/8 of the
    arc's. With σ_s = 1 mm the parameters predict that blend at the predicted ``s`` (the
    window is centred there, not on the parameters' node at the step's straight side,
    0.125 m away, where the blend would be 1/2), with no remainder left (the 8-point rule
    resolves 3/8 exactly). A point sample there (no interval) is the straight's 0, and
    has no remainder either."""
    grid = TrackParameterGrid(step_track)
    s_m = np.array([1000.0 - 0.125])
    params, _ = grid.parameters(s_m)
    eff, var = statistical_parameters(grid, params, sigma_s_m=1e-3, speed_mps=SPEED,
                                      interval_m=interval_m, s_m=s_m)
    lateral, _ = cross_track_basis(params[:, 7:10])
    arc, _ = grid.parameters(np.array([1000.0 + 1e-3]))       # the arc at the step
    kappa_l = float(arc[0, 10:13] @ lateral[0])
    assert abs(kappa_l) == pytest.approx(KAPPA, rel=1e-9)
    predicted = (eff[0, 10:13] + eff[0, 13:16] * (s_m[0] - params[0, 0])) @ lateral[0]
    assert predicted == pytest.approx(fraction * kappa_l, rel=1e-6, abs=1e-15)
    assert var[0, 0] < 1e-6 * SPEED ** 4 * KAPPA ** 2


def test_the_blend_is_linearized_across_the_interval(step_track):
    """σ_s = 0.3 m, the predicted ``s`` on the step, 1 m run per sample: the interval's
    mean is the ramp ``κ (1/2 + x)`` for ``|x| ≤ 1/2`` (x = s' − s_j in m), which the prior
    (±4σ = ±1.2 m) overruns into the flat parts; the parameters carry the regression of
    the 8-point staircase of that ramp, compared here with the same regression of the
    exact ramp (the staircase's steps of 1/8 move it by less than 1/16 of κ), and the
    remainder is what the line misses of the ramp (its variance within 5 % plus the
    staircase's κ²/12·(1/8)² of rounding)."""
    grid = TrackParameterGrid(step_track)
    s_m = np.array([1000.0])
    sigma = 0.3
    params, _ = grid.parameters(s_m)
    eff, var = statistical_parameters(grid, params, sigma_s_m=sigma, speed_mps=SPEED,
                                      interval_m=1.0, s_m=s_m)
    lateral, _ = cross_track_basis(params[:, 7:10])
    kappa_l = float(grid.parameters(np.array([1000.0 + 1e-3]))[0][0, 10:13] @ lateral[0])
    x = sigma * _XI
    w = np.exp(-0.5 * _XI ** 2)
    w /= w.sum()
    ramp = kappa_l * np.clip(0.5 + x, 0.0, 1.0)
    slope = np.sum(w * ramp * x) / np.sum(w * x * x)
    mean = np.sum(w * ramp)
    at_s = (eff[0, 10:13] + eff[0, 13:16] * (s_m[0] - params[0, 0])) @ lateral[0]
    assert at_s == pytest.approx(mean, abs=abs(kappa_l) / 16)
    assert eff[0, 13:16] @ lateral[0] == pytest.approx(slope, abs=abs(kappa_l) / 16 / sigma)
    missed = SPEED ** 4 * np.sum(w * (ramp - mean - slope * x) ** 2)
    rounding = SPEED ** 4 * kappa_l ** 2 / 12 / 64
    assert var[0, 0] == pytest.approx(missed, rel=0.05, abs=rounding)


@pytest.mark.parametrize("sigma", [0.5, 50.0, 400.0])
def test_one_straight_section_takes_the_shortcut_the_quadrature_agrees_with(sigma):
    """Inside one loxodrome `statistical_parameters` returns zero without the quadrature; the
    quadrature (the general path) gives the same to < 1e-20 (m/s²)² on the paper's
    sphere straight at σ_s up to 400 m."""
    track = read_track(TRACKS_DIR / "paper2017.csv")
    grid = TrackParameterGrid(track)
    params, _ = grid.parameters(np.linspace(5000.0, 5040.0, 5))
    offsets = np.clip(sigma * _XI, -MAX_OFFSET_M, MAX_OFFSET_M)
    eff, var = statistical_parameters(grid, params, sigma_s_m=sigma, speed_mps=SPEED)
    assert eff is params and np.all(var == 0.0)
    assert np.all(_quadrature(grid, params, offsets, SPEED) < 1e-20)


def test_outage_across_a_vertical_curve_start_stays_consistent():
    """Regression: navigation grade, outage 100–160 s on curvy.csv, seed 1. Without the
    geometry noise the filter dragged s back 540 m at the vertical curve starting at
    2500 m while σ_s stayed 1.9 m. Bound: the error stays within 4σ_s of the filter."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    sc = replace(get_scenario("curvy"), imu_errors="navigation", outages=((100.0, 60.0),),
                 duration_s=165.0)
    out = run_simulated(track, sc, seed=1)
    est = out.result.estimates
    inside = (est["time_s"] >= 100.0) & (est["time_s"] < 160.0)
    z = np.abs(out.errors.along_track_m[inside]) / est["sigma_s_m"][inside]
    assert z.max() < 4.0
