"""The discrete update (ekf/update.py) against the textbook Kalman equations written with
explicit inverses, scipy's Gaussian log-density, and batch-vs-sequential equivalence."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.stats import multivariate_normal

from ekf.errors import FilterDivergedError, ModelError
from ekf.gating import Gate
from ekf.model import MeasurementModel
from ekf.update import Observation, discrete_update, kalman_update

#: Agreement of algebraically equal formulas in double precision (well-conditioned S).
RTOL = 1e-10


def _problem(rng, n=4, m=3):
    A = rng.normal(size=(n, n))
    P = A @ A.T + 0.5 * np.eye(n)
    H = rng.normal(size=(m, n))
    R = np.diag(rng.uniform(0.1, 1.0, m))
    return rng.normal(size=n), P, H, R, rng.normal(size=m)


def test_update_equals_textbook_kalman(rng):
    """Reference: K = P Hᵀ (H P Hᵀ + R)⁻¹, x⁺ = x + K ν, P⁺ = (I − K H) P."""
    x, P, H, R, innov = _problem(rng)
    x_post, P_post, rec = kalman_update(x, P, innov, H, R)
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(x_post, x + K @ innov, rtol=RTOL)
    np.testing.assert_allclose(P_post, (np.eye(4) - K @ H) @ P, rtol=RTOL, atol=1e-12)
    np.testing.assert_allclose(rec.nis, innov @ np.linalg.inv(S) @ innov, rtol=RTOL)
    ref_ll = multivariate_normal(np.zeros(3), S).logpdf(innov)
    np.testing.assert_allclose(rec.log_likelihood, ref_ll, rtol=RTOL)
    assert rec.accepted.all()


def test_sequential_equals_batch_for_diagonal_noise(rng):
    """Reference: the batch update (same linear problem, scalar processing is exact)."""
    x, P, H, R, innov = _problem(rng)
    xb, Pb, rb = kalman_update(x, P, innov, H, np.diag(R))
    xs, Ps, rs = kalman_update(x, P, innov, H, np.diag(R), sequential=True)
    np.testing.assert_allclose(xs, xb, rtol=RTOL)
    np.testing.assert_allclose(Ps, Pb, rtol=RTOL, atol=1e-12)
    # the sequential NIS components add up to the batch NIS (independent innovations)
    np.testing.assert_allclose(rs.nis_components.sum(), rb.nis, rtol=RTOL)


def test_row_gate_drops_only_the_outlier(rng):
    """Reference: the update computed without the outlier row."""
    x, P, H, R, _ = _problem(rng, m=4)
    S = H @ P @ H.T + R
    innov = np.linalg.cholesky(S) @ np.array([0.3, -0.2, 0.1, 0.0])
    innov[2] += 50.0 * np.sqrt(S[2, 2])
    gate = Gate(probability=0.999, scope="rows")
    x_post, P_post, rec = kalman_update(x, P, innov, H, R, gate=gate)
    assert rec.accepted.tolist() == [True, True, False, True]
    keep = [0, 1, 3]
    x_ref, P_ref, _ = kalman_update(x, P, innov[keep], H[keep], R[np.ix_(keep, keep)])
    np.testing.assert_allclose(x_post, x_ref, rtol=RTOL)
    np.testing.assert_allclose(P_post, P_ref, rtol=RTOL, atol=1e-12)
    x_v, _, rec_v = kalman_update(x, P, innov, H, R, gate=Gate(probability=0.999))
    assert not rec_v.accepted.any() and np.array_equal(x_v, x)


def test_measurement_model_jacobian_against_central_differences(rng):
    """Reference: central differences of h (step 1e-6 m; error O(step²) ≈ 1e-9)."""
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 3)
    model = MeasurementModel.from_expression(x, p, ca.norm_2(x - p) + x[2] ** 2, "range")
    sats = rng.normal(0, 100, (5, 3))
    x0 = rng.normal(size=3)
    z, H = model.evaluate(x0, sats)
    np.testing.assert_allclose(z, np.linalg.norm(x0 - sats, axis=1) + x0[2] ** 2, rtol=1e-14)
    step = 1e-6
    for j in range(3):
        e = np.eye(3)[j] * step
        fd = (model.evaluate(x0 + e, sats)[0] - model.evaluate(x0 - e, sats)[0]) / (2 * step)
        np.testing.assert_allclose(H[:, j], fd, atol=1e-8)
    # the CasADi-VM path gives the same numbers as the compiled rows
    z_vm, H_vm = MeasurementModel(model.h, "range", compiled=False).evaluate(x0, sats)
    np.testing.assert_allclose(z_vm, z, rtol=1e-14)
    np.testing.assert_allclose(H_vm, H, rtol=1e-13, atol=1e-15)


def test_discrete_update_stacks_observations_and_validates(rng):
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 0)
    pos = MeasurementModel.from_expression(x, p, x, "pos")
    x0, P0 = np.array([1.0, 2.0]), np.eye(2)
    obs = Observation(pos, z=np.array([[1.5, 2.5]]), R=np.array([1.0, 1.0]), p=np.zeros((1, 0)))
    x_post, P_post, rec = discrete_update(x0, P0, [obs])
    np.testing.assert_allclose(x_post, [1.25, 2.25], rtol=RTOL)  # equal weights: midpoint
    np.testing.assert_allclose(P_post, 0.5 * np.eye(2), rtol=RTOL)
    with pytest.raises(ModelError):
        Observation(pos, z=np.array([[np.nan, 1.0]]), R=np.ones(2), p=np.zeros((1, 0)))
    with pytest.raises(ModelError):
        Observation(pos, z=np.ones((1, 2)), R=np.ones(3), p=np.zeros((1, 0)))
    with pytest.raises(FilterDivergedError):
        kalman_update(x0, -np.eye(2), np.ones(2), np.eye(2), np.zeros(2))


def test_variances_and_their_diagonal_matrix_update_alike_to_the_bit(rng):
    """Rows given variances (1-D R) or the diagonal matrix of them update alike, to the
    bit; with one full covariance among them the update is `kalman_update` with the
    block-diagonal R built here (scipy's block_diag)."""
    from scipy.linalg import block_diag
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 3)
    model = MeasurementModel.from_expression(x, p, ca.norm_2(x - p), "range")
    sats, x0 = rng.normal(0, 100, (6, 3)), rng.normal(size=3)
    A = rng.normal(size=(3, 3))
    P0 = A @ A.T + np.eye(3)
    z = np.linalg.norm(x0 - sats, axis=1) + rng.normal(0, 0.5, 6)
    var = rng.uniform(0.2, 3.0, 6)
    B = rng.normal(size=(2, 2))
    full = B @ B.T + np.eye(2)                          # correlated: not diagonal

    def rows(R0, R1, R2):
        return [Observation(model, z=z[:3], R=R0, p=sats[:3]),
                Observation(model, z=z[3:4], R=R1, p=sats[3:4]),
                Observation(model, z=z[4:], R=R2, p=sats[4:])]
    a = discrete_update(x0, P0, rows(var[:3], var[3:4], var[4:]))
    b = discrete_update(x0, P0, rows(np.diag(var[:3]), np.diag(var[3:4]), np.diag(var[4:])))
    assert all(np.array_equal(u, v) for u, v in zip(a[:2], b[:2]))
    assert np.array_equal(a[2].innov, b[2].innov) and a[2].nis == b[2].nis
    c = discrete_update(x0, P0, rows(var[:3], np.diag(var[3:4]), full))
    H = np.vstack([model.evaluate(x0, sats[k:k + 1])[1] for k in range(6)])
    nu = z - np.array([model.evaluate(x0, sats[k:k + 1])[0][0] for k in range(6)])
    d = kalman_update(x0, P0, nu, H, block_diag(np.diag(var[:3]), np.diag(var[3:4]), full),
                      groups=np.arange(6))
    np.testing.assert_allclose(c[0], d[0], rtol=1e-12)
    np.testing.assert_allclose(c[1], d[1], rtol=1e-12, atol=1e-14)


def test_evaluated_observations_are_used_at_their_state_only(rng, monkeypatch):
    """Rows stacked at the prior give the update of the observations themselves, to the
    bit (same innovation, Jacobian, variances and row ids); at another state the
    observations are evaluated again (reference: the plain list)."""
    from ekf.update import EvaluatedObservations
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 3)
    model = MeasurementModel.from_expression(x, p, ca.norm_2(x - p), "range")
    sats = rng.normal(0, 100, (6, 3))
    x0 = rng.normal(size=3)
    A = rng.normal(size=(3, 3))
    P0 = A @ A.T + np.eye(3)
    obs = [Observation(model, z=np.linalg.norm(x0 - sats[:4], axis=1) + 0.3, R=np.full(4, 0.5),
                       p=sats[:4]),
           Observation(model, z=np.linalg.norm(x0 - sats[4:], axis=1) - 0.2, R=np.full(2, 2.0),
                       p=sats[4:])]
    z_pred = np.concatenate([model.evaluate(x0, o.p)[0] for o in obs])
    H = np.vstack([model.evaluate(x0, o.p)[1] for o in obs])
    stacked = EvaluatedObservations(obs, x=x0, innov=np.concatenate([o.z.reshape(-1) for o in obs])
                                    - z_pred, H=H, R=np.concatenate([o.R for o in obs]),
                                    groups=np.arange(6))
    assert list(stacked) == obs
    gate = Gate(0.9999, scope="rows")
    for x_at in (x0, x0 + 0.5):
        a = discrete_update(x_at, P0, stacked, gate=gate)
        b = discrete_update(x_at, P0, obs, gate=gate)
        assert all(np.array_equal(u, v) for u, v in zip(a[:2], b[:2]))
        assert np.array_equal(a[2].innov, b[2].innov) and a[2].nis == b[2].nis
    with pytest.raises(ModelError):
        EvaluatedObservations(obs, x=x0, innov=np.zeros(5), H=H, R=np.ones(6),
                              groups=np.arange(6))

    def no_evaluation(*args):
        raise AssertionError("evaluated again")
    monkeypatch.setattr(MeasurementModel, "evaluate", no_evaluation)
    discrete_update(x0.copy(), P0, stacked)            # the same state: not evaluated
    with pytest.raises(AssertionError, match="evaluated again"):
        discrete_update(x0 + 0.5, P0, stacked)


def test_subset_equals_an_observation_made_of_the_rows(rng):
    """`Observation.subset`: the same arrays as an Observation built (and checked) from the
    kept rows' z, R and p, for scalar rows and for rows of two components; a full R is
    refused."""
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    for z_row in (ca.dot(p, x), ca.vertcat(p[0] * x[0], p[1] * x[1])):
        model = MeasurementModel.from_expression(x, p, z_row, "rows")
        m, k = 5, model.k
        obs = Observation(model, z=rng.normal(size=(m, k)), R=rng.uniform(0.5, 2.0, m * k),
                          p=rng.normal(size=(m, 2)))
        keep = np.array([True, False, True, True, False])
        ref = Observation(model, z=obs.z[keep], R=obs.R.reshape(m, k)[keep].reshape(-1),
                          p=obs.p[keep])
        got = obs.subset(keep)
        for name in ("z", "R", "p"):
            assert getattr(got, name).dtype == getattr(ref, name).dtype
            np.testing.assert_array_equal(getattr(got, name), getattr(ref, name))
        assert got.model is model and got.rows == 3
    full = Observation(model, z=np.ones((1, 2)), R=np.eye(2), p=np.zeros((1, 2)))
    with pytest.raises(ModelError):
        full.subset(np.array([True]))
