"""CasADi measurement models: closed form, Jacobians by central differences, batching."""
from __future__ import annotations

import numpy as np
import pytest

from gnss_obs.epoch import PreparedEpoch
from gnss_obs.observables import (build_measurement_model, mapped_measurement_model,
                                  predict_pseudorange, predict_range_rate,
                                  system_bias_matrix)

ATOL_M = 1e-6        # closed-form range at 2e7 m: double precision ~4e-9 m
ATOL_MPS = 1e-9
#: Central differences of a 2e7-m range with h = 1 m: truncation |∂³ρ| h² / 6 ~ 1e-15,
#: round-off 4e-9 m / 2 m = 2e-9; 1e-7 leaves a margin.
ATOL_JAC = 1e-7
H_M = 1.0
H_MPS = 1.0


def _prepared(rng, n: int = 7) -> PreparedEpoch:
    """A synthetic epoch: satellites 20 000 km up in random directions from a point."""
    r0 = np.array([4.77e6, 0.196e6, 4.21e6])
    up = r0 / np.linalg.norm(r0)
    dirs = rng.normal(size=(n, 3)) + 2.0 * up
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    zeros = np.zeros(n)
    return PreparedEpoch(
        gps_time_s=0.0, sv=np.array([f"G{k:02d}" for k in range(1, n + 1)]),
        system=np.array(["G"] * (n - 2) + ["E"] * 2), sat_pos_e=r0 + 2.0e7 * dirs,
        sat_vel_e=rng.normal(scale=3000.0, size=(n, 3)), sat_clock_m=rng.normal(scale=1e4, size=n),
        sat_clock_drift_mps=rng.normal(scale=0.1, size=n), iono_m=rng.uniform(1, 10, n),
        tropo_m=rng.uniform(2, 20, n), elevation=zeros, azimuth=zeros,
        pseudorange_m=zeros, range_rate_mps=zeros, cn0_dbhz=zeros, sigma_pr_m=zeros + 1,
        sigma_rr_mps=zeros + 1)


def test_pseudorange_closed_form(rng):
    p = _prepared(rng)
    r = np.array([4.77e6 + 12.0, 0.196e6 - 3.0, 4.21e6 + 40.0])
    b = rng.normal(scale=1e5, size=len(p))
    rho, H_r, H_b = predict_pseudorange(p, r_e=r, b_m=b)
    geometric = np.linalg.norm(p.sat_pos_e - r, axis=1)
    np.testing.assert_allclose(rho, geometric + b - p.sat_clock_m + p.iono_m + p.tropo_m,
                               rtol=0, atol=ATOL_M)
    np.testing.assert_allclose(H_r, -(p.sat_pos_e - r) / geometric[:, None], atol=1e-15)
    np.testing.assert_array_equal(H_b, 1.0)


def test_range_rate_closed_form(rng):
    p = _prepared(rng)
    r, v, d = np.array([4.77e6, 0.196e6, 4.21e6]), np.array([3.0, -7.0, 0.5]), 41.0
    rr, _, H_v, H_d = predict_range_rate(p, r_e=r, v_e=v, d_mps=d)
    los = p.sat_pos_e - r
    unit = los / np.linalg.norm(los, axis=1, keepdims=True)
    expected = np.einsum("ni,ni->n", unit, p.sat_vel_e - v) + d - p.sat_clock_drift_mps
    np.testing.assert_allclose(rr, expected, rtol=0, atol=ATOL_MPS)
    np.testing.assert_allclose(H_v, -unit, atol=1e-15)
    np.testing.assert_array_equal(H_d, 1.0)


def test_jacobians_match_central_differences(rng):
    """CasADi's symbolic Jacobians against central differences (STYLE.md §2.7)."""
    p = _prepared(rng)
    r, v = np.array([4.77e6, 0.196e6, 4.21e6]), np.array([3.0, -7.0, 0.5])
    _, H_r, _ = predict_pseudorange(p, r_e=r, b_m=0.0)
    _, Hr_rr, Hv_rr, _ = predict_range_rate(p, r_e=r, v_e=v, d_mps=0.0)
    for k in range(3):
        dr = np.zeros(3)
        dr[k] = H_M
        plus, _, _ = predict_pseudorange(p, r_e=r + dr, b_m=0.0)
        minus, _, _ = predict_pseudorange(p, r_e=r - dr, b_m=0.0)
        np.testing.assert_allclose(H_r[:, k], (plus - minus) / (2 * H_M), atol=ATOL_JAC)
        plus, *_ = predict_range_rate(p, r_e=r + dr, v_e=v, d_mps=0.0)
        minus, *_ = predict_range_rate(p, r_e=r - dr, v_e=v, d_mps=0.0)
        np.testing.assert_allclose(Hr_rr[:, k], (plus - minus) / (2 * H_M), atol=1e-12)
        dv = dr * H_MPS / H_M
        plus, *_ = predict_range_rate(p, r_e=r, v_e=v + dv, d_mps=0.0)
        minus, *_ = predict_range_rate(p, r_e=r, v_e=v - dv, d_mps=0.0)
        np.testing.assert_allclose(Hv_rr[:, k], (plus - minus) / (2 * H_MPS), atol=ATOL_JAC)


def test_range_rate_is_time_derivative_of_range(rng):
    """ρ̇ = d/dt |s(t) - r(t)| for straight-line motion (central difference in time)."""
    p = _prepared(rng)
    r, v, h = np.array([4.77e6, 0.196e6, 4.21e6]), np.array([30.0, -7.0, 0.5]), 1e-3
    rr, *_ = predict_range_rate(p, r_e=r, v_e=v, d_mps=0.0)
    sat_drift = p.sat_clock_drift_mps  # the model subtracts it: add it back
    moved = [np.linalg.norm(p.sat_pos_e + s * h * p.sat_vel_e - (r + s * h * v), axis=1)
             for s in (-1.0, 1.0)]
    np.testing.assert_allclose(rr + sat_drift, (moved[1] - moved[0]) / (2 * h), atol=1e-5)


def test_batch_equals_single_satellite(rng):
    """The mapped function gives what the single-satellite function gives row by row."""
    p = _prepared(rng)
    r = np.array([4.77e6, 0.196e6, 4.21e6])
    rho, H_r, _ = predict_pseudorange(p, r_e=r, b_m=5.0)
    single = build_measurement_model().pseudorange
    for k in range(len(p)):
        out = single(r, 5.0, p.sat_pos_e[k], p.sat_clock_m[k], p.delays_m[k])
        assert float(out[0]) == pytest.approx(rho[k], abs=1e-9)
        np.testing.assert_allclose(np.asarray(out[1]).ravel(), H_r[k], atol=1e-15)


@pytest.mark.parametrize("n", [1, 3, 7, 12])
def test_buffered_evaluation_is_the_mapped_functions_call(rng, n):
    """`predict_pseudorange` evaluates the mapped function through its buffer: the same
    numbers, to the bit, as the function called with its arguments (``DM``), a scalar and a
    per-satellite clock, sizes interleaved (each size its own buffer)."""
    for b in (rng.normal(scale=1e5), rng.normal(scale=1e5, size=n)):
        p = _prepared(rng, n + 2)
        p = p.subset(np.arange(n))
        r = np.array([4.77e6, 0.196e6, 4.21e6]) + rng.normal(scale=50.0, size=3)
        rho, H_r, H_b = predict_pseudorange(p, r_e=r, b_m=b)
        predict_pseudorange(_prepared(rng, n + 1), r_e=r, b_m=0.0)    # another size between
        b_sat = np.broadcast_to(np.asarray(b, dtype=float), (n,))
        out = mapped_measurement_model(n).pseudorange(
            r, b_sat[None, :], p.sat_pos_e.T, p.sat_clock_m[None, :], p.delays_m[None, :])
        np.testing.assert_array_equal(rho, np.asarray(out[0]).reshape(-1))
        np.testing.assert_array_equal(H_r, np.asarray(out[1]).reshape(n, 3))
        np.testing.assert_array_equal(H_b, np.asarray(out[2]).reshape(-1))


def test_system_bias_matrix():
    S = system_bias_matrix(["G", "E", "G", "C", "E"], "GEC")
    np.testing.assert_array_equal(S, [[1, 0, 0], [1, 1, 0], [1, 0, 0], [1, 0, 1], [1, 1, 0]])
