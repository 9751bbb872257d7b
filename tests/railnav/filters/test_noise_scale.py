"""The adaptive noise scale of the GNSS rows (railnav/filters/noise_scale.py).

Synthetic innovation sequences ``ν ~ N(0, a + λ b)`` of known ratio λ: the weighted sign
test's bound against the order statistic written out by hand, and against the quantile
of ``λ χ²₁ / m₁`` (SciPy) with its sampling error; λ = 1 leaves the scale at 1 exactly; a
30-m step on one satellite of eight leaves the row rejected by the screen's row test.
Integration: a simulated trip told its σ runs the same to the bit with the scale on and
off (constrained and gnss-only filters).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import chi2

from railnav.errors import ConfigError
from railnav.filters.fault_config import FaultDetectionConfig
from railnav.filters.common import ROW_KINDS
from railnav.filters.noise_scale import (CHI2_1_MEDIAN, NoiseScale, NoiseScaleConfig,
                                         row_ratios, row_scales, scale_bound)
from railnav.jobs.run import run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.io import read_track

SATELLITES = 8
#: Elevations of the synthetic satellites, and their rows' own variances ``b = σ²/sin²``.
ELEVATION_RAD = np.deg2rad(np.linspace(15.0, 80.0, SATELLITES))
SIGMA_M = 3.0
OWN_VAR = (SIGMA_M / np.sin(ELEVATION_RAD)) ** 2


def _epochs(rng, ratio: float, n_epochs: int, *, prior_share: float = 0.0):
    """Rows ``{pseudorange: (ν, a, b)}`` of `n_epochs` epochs of `SATELLITES` rows,
    ``ν ~ N(0, a + ratio b)``, ``a = prior_share b``."""
    a = prior_share * OWN_VAR
    for _ in range(n_epochs):
        nu = rng.standard_normal(SATELLITES) * np.sqrt(a + ratio * OWN_VAR)
        yield {"pseudorange": (nu, a, OWN_VAR)}


def test_chi2_median():
    assert CHI2_1_MEDIAN == pytest.approx(chi2.ppf(0.5, 1), rel=1e-12)


def test_row_ratio_puts_the_nis_at_the_median():
    nu, a, b = np.array([2.0, -0.5]), np.array([0.3, 0.1]), np.array([1.5, 0.2])
    q = row_ratios(nu, a, b)
    assert nu ** 2 / (a + q * b) == pytest.approx(np.full(2, CHI2_1_MEDIAN), rel=1e-12)


def test_scale_bound_with_equal_weights_is_the_sign_test_order_statistic():
    """Equal weights: the ``ceil(n/2 + z √n / 2)``-th largest value."""
    rng = np.random.default_rng(4)
    q = rng.standard_normal(101)
    for z in (0.0, 1.0, 3.0):
        k = math.ceil(101 / 2 + z * math.sqrt(101) / 2)
        assert scale_bound(q, np.ones(101), z=z) == np.sort(q)[::-1][k - 1]
    assert scale_bound(q[:8], np.ones(8), z=3.0) == -math.inf   # 4 + 4.24 > 8 rows


def test_scale_bound_with_a_floor_is_the_larger_of_the_two():
    """The floor's shortcut (no sort when not significant above it) against
    ``max(bound, floor)`` of the full computation, on weighted rows."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        n = int(rng.integers(1, 60))
        q, w = rng.standard_normal(n) + rng.uniform(-1, 2), rng.uniform(0.1, 3.0, n)
        for floor in (0.0, 1.0):
            assert scale_bound(q, w, z=2.0, floor=floor) == max(scale_bound(q, w, z=2.0),
                                                                floor)


@pytest.mark.parametrize("ratio", [4.0, 25.0])
def test_scale_converges_to_the_ratio_within_its_sampling_error(ratio):
    """``a = 0``: the rows' ``q`` are ``λ χ²₁ / m₁`` whatever their weight, so the bound is
    their ``p = ½ − z √Σw² / (2 W)`` quantile, ``λ χ²₁.ppf(p) / m₁``, with the
    sampling error of a weighted quantile, ``√(p (1 − p) Σw²) / (W f(q_p))`` (f the
    density of ``q`` there); the scale is within 4 of those errors. (An 800-epoch
    window: the default's bound is further below λ, module docstring.)"""
    config = NoiseScaleConfig(window_epochs=800)
    scale = NoiseScale(config)
    for rows in _epochs(np.random.default_rng(11), ratio, config.window_epochs):
        scale.add(rows)
    w = np.tile(1.0 / OWN_VAR, config.window_epochs)
    W, W2 = w.sum(), np.dot(w, w)
    p = 0.5 - config.z * math.sqrt(W2) / (2.0 * W)
    x_p = chi2.ppf(p, 1)
    expected = ratio * x_p / CHI2_1_MEDIAN
    density = chi2.pdf(x_p, 1) * CHI2_1_MEDIAN / ratio          # of q = λ χ² / m₁
    error = math.sqrt(p * (1.0 - p) * W2) / W / density
    assert abs(scale.variance_factor["pseudorange"] - expected) < 4.0 * error
    assert scale.variance_factor["pseudorange"] < ratio      # a lower bound: below λ
    assert scale.variance_factor["range_rate"] == 1.0        # no rows of that kind


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_told_right_the_scale_stays_one(seed):
    """λ = 1 (prior variance ``a`` half the rows' own), 600 epochs, seeds chosen before
    the runs: the sign test never finds the NIS significantly high."""
    scale = NoiseScale(NoiseScaleConfig())
    for rows in _epochs(np.random.default_rng(seed), 1.0, 600, prior_share=0.5):
        scale.begin_epoch()
        scale.add(rows)
    assert {h for h in scale.history} == {(1.0, 1.0)}


def test_one_faulty_satellite_keeps_its_step_rejected():
    """A 30-m step on the highest satellite (the rows' own σ 3 m/sin(el): 3.05 m; the
    largest weight, 23 % of it) in every epoch of the window: the scale stays below what
    the good rows give with the faulty ones always above, without the test's margin and
    with infinitely many rows (their weighted quantile ``1 − (½ − share)/(1 − share)``
    of ``χ²₁ / m₁``), and the step, at the scaled σ, still fails the fault screen's row
    test (`FaultDetectionConfig.nis_threshold`)."""
    scale = NoiseScale(NoiseScaleConfig())
    rng = np.random.default_rng(7)
    for rows in _epochs(rng, 1.0, 200):
        nu, a, b = rows["pseudorange"]
        nu[-1] += 30.0
        scale.add(rows)
    share = (1.0 / OWN_VAR[-1]) / np.sum(1.0 / OWN_VAR)
    limit = chi2.ppf(1.0 - (0.5 - share) / (1.0 - share), 1) / CHI2_1_MEDIAN
    factor = scale.variance_factor["pseudorange"]
    assert 1.0 <= factor < limit
    nis = 30.0 ** 2 / (factor * OWN_VAR[-1])
    assert nis > FaultDetectionConfig().nis_threshold


def test_off_keeps_nothing():
    scale = NoiseScale(None)
    scale.add({"pseudorange": (np.full(8, 100.0), np.zeros(8), np.ones(8))})
    assert scale.variance_factor == {"pseudorange": 1.0, "range_rate": 1.0}


def test_row_scales_by_epoch_and_kind():
    history = [(1.0, 1.0), (1.5, 3.0)]
    out = row_scales(history, np.array([0, 1, 1, 1]),
                     np.array(["pseudorange", "pseudorange", "range_rate", "fix_east"],
                              dtype=object))
    assert out[:3].tolist() == [1.0, 1.5, 3.0] and np.isnan(out[3])
    assert np.isnan(row_scales(history, np.array([2]), np.array(["pseudorange"]))).all()


@pytest.mark.parametrize("changes", [{"window_epochs": 0}, {"z": -1.0},
                                     {"max_sigma_factor": 0.5}, {"z": float("nan")}])
def test_bad_configuration_is_refused(changes):
    with pytest.raises(ConfigError, match="noise_scale"):
        NoiseScaleConfig(**changes)


@pytest.mark.parametrize("filter", ["constrained", "gnss-only"])
def test_a_trip_told_its_sigma_runs_as_without_the_scale(filter):
    """A simulated 150-s curvy trip with the filter told the simulator's σ: the scale
    stays 1 at every epoch, and the estimates are those of the run without it, to the
    bit."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    scenario = replace(get_scenario("curvy"), duration_s=150.0)
    config = navigator_config_for(scenario, filter=filter)
    on = run_simulated(track, scenario, config=config, seed=3)
    off = run_simulated(track, scenario, config=replace(config, noise_scale=None), seed=3)
    inn = on.result.innovations
    gnss = inn["kind"].isin(("pseudorange", "range_rate"))
    assert (inn.loc[gnss, "noise_scale"] == 1.0).all()
    assert on.result.estimates.equals(off.result.estimates)


def test_the_window_sums_kept_as_rows_come_and_go_equal_sums_from_scratch():
    """`NoiseScale` keeps each window's Σw, Σw², Σw[q ≥ 1] as epochs enter and leave;
    its factor at every epoch equals the sign test and `scale_bound` on the window's rows
    summed from scratch (second method), through a rise (λ = 3) and back."""
    rng = np.random.default_rng(3)
    cfg = NoiseScaleConfig(window_epochs=20, z=2.0)
    scale, kept, rose = NoiseScale(cfg), {k: [] for k in ROW_KINDS}, 1.0
    for epoch in range(500):
        lam = 3.0 if 150 <= epoch < 300 else 1.0
        rows = {}
        for k in ROW_KINDS:
            n = int(rng.integers(0, 9))
            b, a = rng.uniform(0.5, 5.0, n), rng.uniform(0.0, 1.0, n)
            rows[k] = (rng.normal(0.0, np.sqrt(a + lam * b)), a, b)
        scale.add(rows)
        for k in ROW_KINDS:
            nu, a, b = rows[k]
            kept[k] = (kept[k] + [((nu ** 2 / CHI2_1_MEDIAN - a) / b, 1.0 / b)])[-20:]
            q = np.concatenate([p[0] for p in kept[k]])
            w = np.concatenate([p[1] for p in kept[k]])
            need = 0.5 * w.sum() + 0.5 * cfg.z * np.sqrt(w @ w)
            expected = 1.0 if w[q >= 1.0].sum() < need * (1 - 1e-12) else \
                min(scale_bound(q, w, z=cfg.z, floor=1.0), cfg.max_sigma_factor ** 2)
            assert scale.variance_factor[k] == expected, (epoch, k)
            rose = max(rose, expected)
    assert rose > 2.0                      # the rise was seen, and followed exactly
