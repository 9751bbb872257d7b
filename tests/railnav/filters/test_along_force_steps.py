"""The accelerometer biases' step from the along-track specific force
(`railnav.filters.along_force_steps.AlongForceSteps`; issue 14, outage_20min seed 5).

References: (1) a Monte Carlo of the triad error ``(S + M) Δf`` with ``S``, ``M`` drawn as
`strapdown.imu_errors` draws them, for ``Δf = (−1, 0, 0)`` m/s² (braking from cruise);
(2) the closed form without information, ``σ² max_t (a(t) − a(0))²``, for a braking, a
stop and a start cut into chunks in two ways (the uniform record's 1-s chunks and a
jittered log's, cut again at its dropouts): the total must not depend on the cuts, nor
grow when ``a`` returns; (3) a Monte Carlo of a scalar Kalman filter that ties the bias
``b + k a(t)`` (``k ~ N(0, σ²)``) at every chunk, with the envelope as its only model of
``k``: its variance must cover the sample variance of its error at every chunk, and equal
it where nothing tied the bias since the force last moved; (4) the low-pass filter of the
force against its closed form for a ramp, ``y(t) = r (t − τ (1 − e^{−t/τ}))``, fed in chunks
cut in two ways.
"""
from __future__ import annotations

import numpy as np
import pytest

from railnav.filters.along_force_steps import AlongForceSteps, smoothed_along_force
from strapdown.imu_errors import imu_grade

DRAWS = 40_000
#: 5 standard errors of a sample variance of a Gaussian (se = sqrt(2/N)).
RATIO_TOL = 5.0 * np.sqrt(2.0 / DRAWS)


def _force_mps2(t_s):
    """Cruise (0), braking to −0.8 m/s² over 10 s from 20 s, held to 60 s, a stop
    (−0.8 → 0 at 60 s), then traction +0.5 m/s² from 90 s."""
    t = np.asarray(t_s, dtype=float)
    ramp = np.clip((t - 20.0) / 10.0, 0.0, 1.0)
    return np.where(t < 60.0, -0.8 * ramp, np.where(t < 90.0, 0.0, 0.5))


def _chunk_means(edges_s):
    """Time means of `_force_mps2` over the chunks between `edges_s` (fine quadrature)."""
    out = []
    for a, b in zip(edges_s[:-1], edges_s[1:]):
        t = np.linspace(a, b, 401)
        out.append(np.trapezoid(_force_mps2(t), t) / (b - a))
    return np.array(out)


def test_the_step_is_the_monte_carlo_variance_of_the_triad_error():
    """Braking from cruise, MEMS: 0 → −1 m/s² without information between; the paper2017
    grade (no scale factor or misalignment) gets no envelope."""
    imu = imu_grade("mems")
    steps = AlongForceSteps(imu)
    assert np.all(steps.variances(0.0, kept=np.ones(3)) == 0.0)
    added = steps.variances(-1.0, kept=np.ones(3))
    rng = np.random.default_rng(15)
    S = rng.normal(0.0, imu.accel_scale_factor_ppm * 1e-6, (DRAWS, 3))
    M = rng.normal(0.0, imu.accel_misalignment_rad, (DRAWS, 3, 3))
    M[:, [0, 1, 2], [0, 1, 2]] = 0.0
    x = np.array([-1.0, 0.0, 0.0])
    error = S * x + np.einsum("nij,j->ni", M, x)
    for axis in range(3):
        assert np.var(error[:, axis]) / added[axis] == pytest.approx(1.0, abs=RATIO_TOL)
    assert AlongForceSteps.for_grade(imu_grade("paper2017")) is None


def test_without_information_the_total_is_the_largest_excursion_whatever_the_cuts():
    imu = imu_grade("tactical")
    uniform = np.arange(0.0, 121.0, 1.0)
    rng = np.random.default_rng(17)
    cuts = rng.uniform(0.0, 120.0, 50)            # a jittered log's dropouts cut 50 more
    jittered = np.unique(np.concatenate([uniform + rng.uniform(-1e-3, 1e-3, uniform.size)
                                         * (uniform > 0) * (uniform < 120), cuts]))
    totals = []
    for edges in (uniform, jittered):
        steps = AlongForceSteps(imu)
        given = sum(steps.variances(a, kept=np.ones(3)) for a in _chunk_means(edges))
        totals.append(given)
    # the largest |a − a(0)| is the held braking, 0.8 m/s² (the start's +0.5 is less)
    expected = np.array([(imu.accel_scale_factor_ppm * 1e-6) ** 2,
                         imu.accel_misalignment_rad ** 2,
                         imu.accel_misalignment_rad ** 2]) * 0.8 ** 2
    for total in totals:
        np.testing.assert_allclose(total, expected, rtol=1e-12)


def test_a_change_of_sign_gives_the_change_squared():
    """Braking −0.5 → traction +0.5 m/s²: ``σ² · 1`` (a variance of ``Δ(a²)`` gives 0)."""
    imu = imu_grade("tactical")
    steps = AlongForceSteps(imu)
    steps.variances(-0.5, kept=np.ones(3))
    added = steps.variances(0.5, kept=np.ones(3))
    assert added[0] == pytest.approx((imu.accel_scale_factor_ppm * 1e-6) ** 2, rel=1e-12)
    assert added[2] == pytest.approx(imu.accel_misalignment_rad ** 2, rel=1e-12)


def _scalar_filter(force, *, sigma_k, sigma_b, sigma_obs, tie, rng):
    """Monte Carlo of a scalar Kalman filter of the effective bias ``b + k a`` observed
    (noise `sigma_obs`) in the chunks where `tie` is true; returns its variance and the
    sample variance of its error after each chunk."""
    k = rng.normal(0.0, sigma_k, DRAWS)
    b = rng.normal(0.0, sigma_b, DRAWS)
    estimate, variance = np.zeros(DRAWS), sigma_b ** 2     # force[0] is 0
    steps = AlongForceSteps(imu_grade("tactical"))
    steps.coefficients = np.full(3, sigma_k ** 2)
    expected = None
    filter_var, error_var = [], []
    for j, a in enumerate(force):
        kept = np.ones(3) if expected is None else np.full(3, variance / expected)
        variance = variance + steps.variances(a, kept=kept)[0]
        expected = variance
        if tie[j]:
            gain = variance / (variance + sigma_obs ** 2)
            y = b + k * a + rng.normal(0.0, sigma_obs, DRAWS)
            estimate = estimate + gain * (y - estimate)
            variance = (1.0 - gain) * variance
        filter_var.append(variance)
        error_var.append(np.var(estimate - (b + k * a)))
    return np.array(filter_var), np.array(error_var)


def test_the_envelope_covers_a_tied_filter_and_is_exact_in_an_outage():
    """GNSS to 20 s (the bias tied every chunk), then an outage through the braking, the
    stop and the start (`_force_mps2`, with a force of 0.3 m/s² from 5 to 12 s, tied)."""
    t = np.arange(0.5, 120.0, 1.0)
    force = _force_mps2(t) + np.where((t > 5.0) & (t < 12.0), 0.3, 0.0)
    f_var, e_var = _scalar_filter(force, sigma_k=1.0, sigma_b=0.5, sigma_obs=0.3,
                                  tie=t < 20.0, rng=np.random.default_rng(18))
    assert np.all(e_var <= f_var * (1.0 + RATIO_TOL))
    held = (t > 20.0) & (t < 60.0)     # braking, the largest excursion since the tie
    np.testing.assert_allclose(e_var[held] / f_var[held], 1.0, atol=RATIO_TOL)


def test_the_smoothed_force_is_the_closed_form_whatever_the_cuts():
    """A ramp ``f = r t`` from ``y(0) = 0`` sampled at 100 Hz, once in 1-s chunks, once
    jittered (±1 ms), with 5 dropouts of 5 samples and cut at 50 random times."""
    rate, tau = 0.3, 0.5
    uniform = np.arange(0.0, 20.0 + 1e-9, 0.01)
    rng = np.random.default_rng(19)
    jittered = uniform + rng.uniform(-1e-3, 1e-3, uniform.size) * (uniform > 0)
    for start in rng.choice(np.arange(100, 1900), 5, replace=False):
        jittered[start:start + 5] = np.nan
    jittered = jittered[np.isfinite(jittered)]
    for times, cuts in ((uniform, np.arange(100, uniform.size, 100)),
                        (jittered, np.unique(rng.integers(1, jittered.size, 50)))):
        last, out = None, []
        for chunk in np.split(times, cuts):
            y, last = smoothed_along_force(chunk, rate * chunk, last, time_constant_s=tau)
            out.extend(zip(chunk, y))
        t_end, y = np.array(out).T
        expected = rate * (t_end - tau * (1.0 - np.exp(-t_end / tau)))
        np.testing.assert_allclose(y, expected, rtol=0.0, atol=1e-12)
