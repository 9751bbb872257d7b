"""Weighted least squares, χ² fault detection/exclusion and protection levels."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize, stats

from gnss_obs.raim import (chi2_threshold, detection_noncentrality, fault_detection_exclusion,
                           huber_wls, protection_levels, wls_step)

RTOL = 1e-12


def _geometry(rng, n: int = 9) -> np.ndarray:
    """Unit lines of sight above the horizon (ENU) with a clock column."""
    d = rng.normal(size=(n, 3))
    d[:, 2] = np.abs(d[:, 2]) + 0.2
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.hstack([-d, np.ones((n, 1))])


def test_weighted_mean_closed_form():
    """H = ones: the solution is the inverse-variance weighted mean, variance 1/Σ(1/σ²)."""
    z = np.array([1.0, 2.0, 4.0])
    sigma = np.array([1.0, 2.0, 4.0])
    w = 1.0 / sigma ** 2
    step = wls_step(np.ones((3, 1)), z, sigma)
    assert step.dx[0] == pytest.approx((w @ z) / w.sum(), rel=RTOL)
    assert step.cov[0, 0] == pytest.approx(1.0 / w.sum(), rel=RTOL)
    assert step.dof == 2
    assert step.test_statistic == pytest.approx(float(w @ (z - step.dx[0]) ** 2), rel=RTOL)


def test_leverages_sum_to_number_of_unknowns(rng):
    H = _geometry(rng)
    step = wls_step(H, rng.normal(size=len(H)), rng.uniform(0.5, 2.0, len(H)))
    assert step.leverage.sum() == pytest.approx(H.shape[1], rel=1e-12)


def test_exclusion_removes_the_faulty_measurement(rng):
    H = _geometry(rng, 10)
    sigma = np.full(10, 1.0)
    z = rng.normal(size=10) * sigma
    z[6] += 80.0
    fde = fault_detection_exclusion(H, z, sigma, p_false_alarm=1e-3, max_exclusions=2)
    assert fde.n_excluded == 1 and not fde.kept[6] and fde.raim_ok


def test_detection_only_flags_without_excluding(rng):
    H = _geometry(rng, 10)
    z = rng.normal(size=10)
    z[3] += 80.0
    fde = fault_detection_exclusion(H, z, np.ones(10), p_false_alarm=1e-3, max_exclusions=0)
    assert fde.n_excluded == 0 and not fde.raim_ok


def test_no_test_without_redundancy(rng):
    H = _geometry(rng, 4)
    fde = fault_detection_exclusion(H, rng.normal(size=4), np.ones(4), p_false_alarm=1e-3,
                                    max_exclusions=3)
    assert fde.step.dof == 0 and not fde.raim_ok and fde.n_excluded == 0
    assert chi2_threshold(0, 1e-3) == np.inf


def test_false_alarm_rate_matches_threshold(rng):
    """Fault-free Gaussian residuals fail the test with the chosen probability
    (Monte Carlo, 4000 trials: binomial 3σ band)."""
    p_fa, trials = 0.05, 4000
    H = _geometry(rng, 8)
    alarms = sum(not fault_detection_exclusion(H, rng.normal(size=8), np.ones(8),
                                               p_false_alarm=p_fa, max_exclusions=0).raim_ok
                 for _ in range(trials))
    assert abs(alarms / trials - p_fa) < 3 * np.sqrt(p_fa * (1 - p_fa) / trials)


def test_noncentrality_gives_the_missed_detection_probability(rng):
    """Sampling χ²(dof, λ) (a mean shift of sqrt(λ) on one of dof unit normals) falls below
    the threshold with probability p_md (Monte Carlo, 20000 samples, 3σ band)."""
    dof, p_fa, p_md, n = 4, 1e-2, 0.1, 20_000
    lam = detection_noncentrality(dof, p_fa, p_md)
    x = rng.normal(size=(n, dof))
    x[:, 0] += np.sqrt(lam)
    missed = np.mean((x ** 2).sum(axis=1) < chi2_threshold(dof, p_fa))
    assert abs(missed - p_md) < 3 * np.sqrt(p_md * (1 - p_md) / n)
    assert chi2_threshold(dof, p_fa) == pytest.approx(stats.chi2.isf(p_fa, dof))


def test_protection_level_bounds_the_worst_undetected_bias(rng):
    """A bias on the measurement with the largest horizontal slope, sized so that the test
    statistic's non-centrality is exactly λ, moves the noise-free horizontal solution by
    exactly HPL (the definition of the slope method, Brown 1992)."""
    H = _geometry(rng, 9)
    sigma = rng.uniform(0.5, 2.0, 9)
    step = wls_step(H, np.zeros(9), sigma)
    hpl, vpl = protection_levels(step, horizontal=(0, 1), vertical=2, p_false_alarm=1e-3,
                                 p_missed_detection=1e-3)
    lam = detection_noncentrality(step.dof, 1e-3, 1e-3)
    slopes = np.hypot(step.gain[0], step.gain[1]) / np.sqrt(1 - step.leverage)
    i = int(np.argmax(slopes))
    bias = np.zeros(9)
    bias[i] = sigma[i] * np.sqrt(lam / (1 - step.leverage[i]))
    biased = wls_step(H, bias, sigma)
    assert biased.test_statistic == pytest.approx(lam, rel=1e-9)
    # the boundary fault's mean error plus the noise term (Rayleigh on the major-axis σ)
    sigma_major = np.sqrt(np.linalg.eigvalsh(step.cov[:2, :2]).max())
    noise_h = np.sqrt(-2 * np.log(1e-3)) * sigma_major
    assert np.hypot(biased.dx[0], biased.dx[1]) + noise_h == pytest.approx(hpl, rel=1e-9)
    slopes_v = np.abs(step.gain[2]) / np.sqrt(1 - step.leverage)
    noise_v = stats.norm.isf(0.5e-3) * np.sqrt(step.cov[2, 2])
    assert vpl == pytest.approx(slopes_v.max() * np.sqrt(lam) + noise_v, rel=1e-9)


def test_singular_geometry_raises():
    H = np.hstack([np.ones((5, 1)), np.ones((5, 1))])
    with pytest.raises(np.linalg.LinAlgError):
        wls_step(H, np.zeros(5), np.ones(5))


def test_huber_location_solves_the_estimating_equation():
    """The Huber M-estimate of a location with known σ is the root of
    Σ ψ((z_i - μ)/σ_i)/σ_i = 0, ψ(u) = clip(u, -k, k) (Huber 1964), found here by brentq."""
    z = np.array([0.3, -0.5, 1.1, 0.2, -0.9, 25.0, 0.4])
    sigma = np.array([1.0, 1.0, 2.0, 1.0, 1.5, 1.0, 1.0])
    k = 1.5
    step, sigma_eff = huber_wls(np.ones((7, 1)), z, sigma, huber_k=k, max_iter=100, tol=1e-14)
    mu = optimize.brentq(lambda m: np.sum(np.clip((z - m) / sigma, -k, k) / sigma), -10, 10,
                         xtol=1e-14)
    assert step.dx[0] == pytest.approx(mu, abs=1e-10)
    assert sigma_eff[5] == pytest.approx(sigma[5] * np.sqrt(abs(z[5] - mu) / k), rel=1e-6)
    assert np.all(sigma_eff[:5] == sigma[:5])


def test_huber_keeps_excluding_gross_faults(rng):
    H = _geometry(rng, 10)
    z = rng.normal(size=10)
    z[2] += 100.0
    fde = fault_detection_exclusion(H, z, np.ones(10), p_false_alarm=1e-3, max_exclusions=2,
                                    huber_k=1.5)
    assert not fde.kept[2] and fde.n_excluded == 1


def test_chi2_threshold_is_scipy_stats_to_the_bit():
    """Reference: ``scipy.stats.chi2.isf`` (the threshold no longer imports scipy.stats)."""
    from scipy import stats
    for dof in (1, 2, 5, 11, 30):
        for p_fa in (1e-7, 1e-5, 1e-3, 0.05):
            assert chi2_threshold(dof, p_fa) == float(stats.chi2.isf(p_fa, dof))


def _reference_wls(H, z, sigma):
    """The solution the textbook way: SciPy's Cholesky factor and solve of the normal
    matrix (what `wls_step` calls LAPACK for directly)."""
    from scipy import linalg
    A, y = H / sigma[:, None], z / sigma
    cov = linalg.cho_solve(linalg.cho_factor(A.T @ A), np.eye(H.shape[1]))
    dx = cov @ A.T @ y
    return dx, cov, (y - A @ dx) * sigma


def _reference_huber(H, z, sigma, huber_k, max_iter=10, tol=1e-6):
    """Huber IRLS written out: solve, reweight from the residuals, until the weights settle."""
    weight = np.ones(z.size)
    dx, cov, r = _reference_wls(H, z, sigma)
    for _ in range(max_iter):
        u = np.abs(r / sigma)
        new = np.where(u <= huber_k, 1.0, huber_k / np.maximum(u, huber_k))
        done = np.max(np.abs(new - weight)) < tol
        weight = new
        dx, cov, r = _reference_wls(H, z, sigma / np.sqrt(weight))
        if done:
            break
    return dx, cov, r


def test_wls_and_huber_equal_the_scipy_cholesky_solution_to_the_bit(rng):
    """The direct LAPACK calls and the IRLS that solves only residuals until the last
    step give the same bits as SciPy's cho_factor/cho_solve in the plain IRLS, with
    outliers (Huber weights < 1) and without."""
    for trial in range(200):
        H = _geometry(rng, n=int(rng.integers(5, 13)))
        sigma = rng.uniform(0.5, 5.0, len(H))
        z = rng.normal(size=len(H)) * sigma
        if trial % 2:
            z[rng.integers(len(H))] += 30.0 * sigma.max()
        step = wls_step(H, z, sigma)
        for got, want in zip((step.dx, step.cov, step.residual), _reference_wls(H, z, sigma)):
            np.testing.assert_array_equal(got, want)
        hstep, _ = huber_wls(H, z, sigma, huber_k=1.5)
        for got, want in zip((hstep.dx, hstep.cov, hstep.residual),
                             _reference_huber(H, z, sigma, 1.5)):
            np.testing.assert_array_equal(got, want)


def test_huber_without_reweighting_is_the_plain_wls_step(rng):
    """Residuals all within huber_k σ (the weights stay 1): `huber_wls` returns the solution
    of its one iteration (not solved again), equal in every field to `wls_step` at the σ
    (a second call); with a residual beyond huber_k, equal to `wls_step` at the inflated σ
    it returns."""
    fields = ("dx", "cov", "residual", "standardized", "leverage", "gain")
    for trial in range(100):
        H = _geometry(rng, n=int(rng.integers(5, 13)))
        sigma = rng.uniform(0.5, 5.0, len(H))
        # whitened post-fit residuals are a projection of z/σ: |r_i/σ_i| <= |z/σ| < 0.7
        z = rng.uniform(-0.2, 0.2, len(H)) * sigma
        if trial % 2:
            z[0] += 40.0 * sigma[0]
        hstep, sigma_eff = huber_wls(H, z, sigma, huber_k=1.5)
        if trial % 2 == 0:
            assert np.array_equal(sigma_eff, sigma)
        want = wls_step(H, z, sigma_eff)
        for name in fields:
            np.testing.assert_array_equal(getattr(hstep, name), getattr(want, name))
        assert (hstep.test_statistic, hstep.dof) == (want.test_statistic, want.dof)
