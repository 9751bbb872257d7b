"""ekf/correlated.py against the Gaussian conditional of the step written out directly.

Reference: ``x_{k+1}`` and ``y_k`` are jointly Gaussian given the past, with
``Cov(x_{k+1}, y_k) = Φ P Hᵀ + M`` and ``Cov(y_k) = H P Hᵀ + R``; the conditional mean and
covariance of ``x_{k+1}`` are then ``E x_{k+1} + C S⁻¹ ν`` and ``Φ P Φᵀ + Q − C S⁻¹ Cᵀ``
(explicit inverses here, on purpose: a second method)."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.correlated import correlated_step
from ekf.errors import ModelError
from ekf.gating import Gate
from ekf.linear import predict_linear

#: Agreement of algebraically equal formulas in double precision (well-conditioned S).
RTOL = 1e-10
ATOL = 1e-12


def _problem(rng, n=4, m=2):
    A = rng.normal(size=(n, n))
    P = A @ A.T + 0.5 * np.eye(n)
    # joint covariance of (w, v), SPD, with a non-zero cross block M
    J = rng.normal(size=(n + m, n + m))
    joint = J @ J.T + 0.2 * np.eye(n + m)
    Q, M, R = joint[:n, :n], joint[:n, n:], joint[n:, n:]
    Phi = np.eye(n) + 0.1 * rng.normal(size=(n, n))
    H = rng.normal(size=(m, n))
    return rng.normal(size=n), P, Phi, Q, M, H, R, rng.normal(size=n), rng.normal(size=m)


def _conditional(x, P, Phi, Q, M, H, R, Bu, innov):
    C = Phi @ P @ H.T + M
    S_inv = np.linalg.inv(H @ P @ H.T + R)
    return Phi @ x + Bu + C @ S_inv @ innov, Phi @ P @ Phi.T + Q - C @ S_inv @ C.T


def test_step_equals_gaussian_conditional(rng):
    x, P, Phi, Q, M, H, R, Bu, innov = _problem(rng)
    x_next, P_next, rec = correlated_step(x, P, innov, H, R, Phi=Phi, Q=Q, M=M, Bu=Bu)
    x_ref, P_ref = _conditional(x, P, Phi, Q, M, H, R, Bu, innov)
    np.testing.assert_allclose(x_next, x_ref, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(P_next, P_ref, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(rec.S, H @ P @ H.T + R, rtol=RTOL)


def test_uncorrelated_noise_is_update_then_predict(rng):
    """With ``M = 0`` the step is the usual filtered-then-predicted estimate."""
    x, P, Phi, Q, _, H, R, Bu, innov = _problem(rng)
    M = np.zeros((x.size, innov.size))
    x_next, P_next, _ = correlated_step(x, P, innov, H, R, Phi=Phi, Q=Q, M=M, Bu=Bu)
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    x_ref, P_ref = predict_linear(x + K @ innov, (np.eye(x.size) - K @ H) @ P, Phi, Q, Bu)
    np.testing.assert_allclose(x_next, x_ref, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(P_next, P_ref, rtol=RTOL, atol=ATOL)


def test_rejected_row_is_left_out_of_update_and_decorrelation(rng):
    """Reference: the conditional given the accepted row only."""
    x, P, Phi, Q, M, H, R, Bu, _ = _problem(rng)
    S = H @ P @ H.T + R
    innov = np.array([0.1 * np.sqrt(S[0, 0]), 100.0 * np.sqrt(S[1, 1])])
    gate = Gate(kind="trace", scope="rows", trace_factor=9.0)
    x_next, P_next, rec = correlated_step(x, P, innov, H, R, Phi=Phi, Q=Q, M=M, Bu=Bu,
                                          gate=gate)
    assert rec.accepted.tolist() == [True, False]
    x_ref, P_ref = _conditional(x, P, Phi, Q, M[:, :1], H[:1], R[:1, :1], Bu, innov[:1])
    np.testing.assert_allclose(x_next, x_ref, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(P_next, P_ref, rtol=RTOL, atol=ATOL)


def test_all_rejected_is_pure_prediction(rng):
    x, P, Phi, Q, M, H, R, Bu, _ = _problem(rng)
    innov = 1e6 * np.ones(2)
    gate = Gate(kind="trace", trace_factor=4.0)
    x_next, P_next, rec = correlated_step(x, P, innov, H, R, Phi=Phi, Q=Q, M=M, Bu=Bu,
                                          gate=gate)
    assert not rec.accepted.any()
    x_ref, P_ref = predict_linear(x, P, Phi, Q, Bu)
    np.testing.assert_allclose(x_next, x_ref, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(P_next, P_ref, rtol=RTOL, atol=ATOL)


def test_shape_mismatch_raises(rng):
    x, P, Phi, Q, M, H, R, Bu, innov = _problem(rng)
    with pytest.raises(ModelError, match="shapes"):
        correlated_step(x, P, innov, H, R, Phi=Phi, Q=Q, M=M.T, Bu=Bu)
