"""The single-point fixes' own noise scale (`railnav.navigation.spp_epochs`, "Scale"):
the pseudoranges' k² estimated from the spawn test's fixes' own post-fit residuals,
whatever the hypotheses (it decides whether a spawn restarts the bank's scale; the fixes
keep the told σ's covariance).

References: the residuals' closed form (the whitened hat matrix by NumPy's least
squares) and their variance ``σ²(1 − h)`` by simulation; the simulator's truth and the
χ²₂ mean 2 of an honest horizontal error; the fixes unscaled (``noise_scale`` None).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from railnav.navigation.spp_epochs import EpochSppFixes, residual_rows
from railnav.simulation.scenarios import get_scenario
from trackmodel.earth import C_n_e, geodetic_to_ecef

SIMULATED_PR_M = 3.0


def test_residual_rows_are_the_whitened_residuals_over_their_redundancy():
    """ν = r / √(1 − h) with r the weighted least-squares residuals and h the whitened hat
    matrix's diagonal (NumPy's `lstsq` and an explicit projection); over 4000 draws the
    mean of ν²/σ² of each row is 1 within 4 standard errors (√(2/4000))."""
    rng = np.random.default_rng(3)
    H = np.hstack([rng.standard_normal((8, 3)), np.ones((8, 1))])
    sigma = np.linspace(1.0, 4.0, 8)
    A = H / sigma[:, None]
    hat = A @ np.linalg.solve(A.T @ A, A.T)
    ratios = []
    for _ in range(4000):
        z = H @ rng.standard_normal(4) + sigma * rng.standard_normal(8)
        nu, a, b = residual_rows(H, z, sigma)
        x = np.linalg.lstsq(A, z / sigma, rcond=None)[0]
        r = z - H @ x
        np.testing.assert_allclose(nu, r / np.sqrt(1.0 - np.diag(hat)), rtol=1e-9,
                                   atol=1e-12)
        assert np.all(a == 0.0) and np.array_equal(b, sigma ** 2)
        ratios.append(nu ** 2 / b)
    assert np.all(np.abs(np.mean(ratios, axis=0) - 1.0) < 4.0 * np.sqrt(2.0 / 4000))


@pytest.fixture(scope="module")
def trip():
    from railnav.simulation.trip import simulate_trip
    scenario = replace(get_scenario("curvy"), duration_s=300.0, outages=(),
                       sigma_pseudorange_m=SIMULATED_PR_M)
    return scenario, simulate_trip(scenario, seed=3, systems="G")


def _fixes(scenario, trip, told_m: float, scaled: bool = True):
    """Every epoch's fix in order, and the fixes' scale's k² before each."""
    from railnav.navigation.navigator import trip_samples
    from railnav.simulation.trip import navigator_config_for
    config = navigator_config_for(scenario, systems="G")
    config = replace(config, measurement=replace(config.measurement, sigma_pr_m=told_m),
                     **({} if scaled else {"noise_scale": None}))
    data = trip.sensor_data()
    samples = trip_samples(data, config)
    solver = EpochSppFixes.of(samples.gnss, data, config)
    k2 = []
    for k in range(len(samples.gnss.epochs)):
        k2.append(solver.noise_scale.variance_factor["pseudorange"])
        solver.solve(k)
    return solver.fixes, np.array(k2)


def _nees(trip, fixes) -> np.ndarray:
    """The fixes' horizontal errors against the truth, whitened by their covariance."""
    truth = trip.truth
    lat, lon, h = (np.interp(fixes.time_s, truth.time_s, v)
                   for v in (truth.lat, truth.lon, truth.h))
    r_fix = np.asarray(geodetic_to_ecef(fixes.lat, fixes.lon, fixes.h_m)).reshape(-1, 3)
    r_true = np.asarray(geodetic_to_ecef(lat, lon, h)).reshape(-1, 3)
    enu = np.einsum("kji,kj->ki", C_n_e(lat, lon).reshape(-1, 3, 3), r_fix - r_true)[:, :2]
    return np.einsum("ki,kij,kj->k", enu, np.linalg.inv(fixes.cov_n_m2[:, :2, :2]), enu)


def test_told_right_the_fixes_are_those_without_the_scale(trip):
    """σ told as simulated: k² stays 1 and every fix is the unscaled one, to the bit."""
    scaled, k2 = _fixes(*trip, SIMULATED_PR_M)
    plain, _ = _fixes(*trip, SIMULATED_PR_M, scaled=False)
    assert np.all(k2 == 1.0)
    for name in ("lat", "lon", "cov_n_m2"):
        assert np.array_equal(getattr(scaled, name), getattr(plain, name))


def test_told_too_small_the_scale_measures_the_fixes_errors(trip):
    """Pseudoranges of 3 m told 1 m (λ = 9): after 60 epochs k² is between half of 9 and 9
    (a lower confidence bound, biased low), and the fixes' covariance times it brings
    their horizontal NEES against the truth (χ²₂: mean 2 when honest) from above 6 to
    below 4 (measured: k² 4.96-7.33, NEES 21.0 and 3.36). The fixes themselves keep the
    told σ's covariance (module docstring, "Scale"): positions and covariance are those
    without the scale."""
    fixes, k2 = _fixes(*trip, 1.0)
    plain, _ = _fixes(*trip, 1.0, scaled=False)
    for name in ("lat", "lon", "cov_n_m2"):
        assert np.array_equal(getattr(fixes, name), getattr(plain, name))
    later = slice(60, None)
    assert np.all((k2[later] > 4.5) & (k2[later] <= 9.0))
    scaled = replace(plain, cov_n_m2=plain.cov_n_m2 * k2[:, None, None])
    assert _nees(trip[1], scaled)[later].mean() < 4.0
    assert _nees(trip[1], plain)[later].mean() > 6.0
