"""The continuous–discrete driver (ekf/cd_filter.py): a linear-Gaussian run against an
exact Kalman filter written here with textbook equations (one-step predictor with
correlated noise, Simon 2006 §7.1, and the standard discrete update), streaming, backends
and input validation."""
from __future__ import annotations

from types import SimpleNamespace

import casadi as ca
import numpy as np
import pytest

from ekf.cd_filter import CdFilter, FilterConfig, _concat, _joined_step_data, step_data
from ekf.errors import ModelError
from ekf.history import concatenate_results
from ekf.model import MeasurementModel
from ekf.series import Epoch, InputSeries
from ekf.step import StepData
from ekf.update import Observation

#: Same linear algebra in a different order, 200 steps: relative agreement.
RTOL_EXACT = 1e-9
DT = 0.01  # s
STEPS = 200
EVERY = 25  # samples between discrete updates
R_POS = 0.05  # m², discrete position-measurement variance
Q_C = np.array([0.7, 0.2])
R_C = np.array([0.05])


def _scenario(tracking_system, rng):
    model = tracking_system.model("drv")
    t = np.arange(STEPS + 1) * DT
    z_c = rng.normal(size=(STEPS + 1, 1))
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 0)
    pos = MeasurementModel.from_expression(x, p, x[0], "pos")
    z_d = {k: rng.normal() for k in range(EVERY, STEPS + 1, EVERY)}
    epochs = [Epoch(t[k], [Observation(pos, np.array([[z]]), np.array([R_POS]),
                                       np.zeros((1, 0)))]) for k, z in z_d.items()]
    samples = InputSeries(t=t, u=np.zeros((STEPS + 1, 0)), q_c=Q_C, z_c=z_c, r_c=R_C)
    return model, samples, epochs, z_c, z_d


def _exact_kf(sys_, x, P, z_c, z_d):
    m = sys_.discrete(DT, Q_C, R_C)
    Phi, Q, R, M, H = m["Phi"], m["Q"], m["R"], m["M"], sys_.H
    H_d = np.array([[1.0, 0.0]])
    nis = []
    for k in range(STEPS + 1):
        if k in z_d:
            S = H_d @ P @ H_d.T + R_POS
            nu = z_d[k] - H_d @ x
            nis.append(float(nu @ np.linalg.inv(S) @ nu))
            K = P @ H_d.T @ np.linalg.inv(S)
            x, P = x + K @ nu, (np.eye(2) - K @ H_d) @ P
        if k == STEPS:
            break
        S = H @ P @ H.T + R
        K = (Phi @ P @ H.T + M) @ np.linalg.inv(S)
        x = Phi @ x + K @ (z_c[k] - H @ x)
        P = Phi @ P @ Phi.T + Q - K @ S @ K.T
    return x, P, np.array(nis)


@pytest.mark.parametrize("backend", ["compiled", "casadi"])
def test_linear_run_equals_exact_kalman_filter(tracking_system, rng, backend):
    model, samples, epochs, z_c, z_d = _scenario(tracking_system, rng)
    x0, P0 = np.array([0.3, -0.1]), np.diag([2.0, 1.0])
    res = CdFilter(model, FilterConfig(backend=backend)).run(samples, epochs, x0=x0, P0=P0)
    x_ref, P_ref, nis_ref = _exact_kf(tracking_system, x0, P0, z_c, z_d)
    np.testing.assert_allclose(res.x_final, x_ref, rtol=RTOL_EXACT)
    np.testing.assert_allclose(res.P_final, P_ref, rtol=RTOL_EXACT)
    np.testing.assert_allclose(res.nis_d, nis_ref, rtol=RTOL_EXACT)
    assert res.x.shape == (STEPS, 2) and res.nis_c_count == STEPS
    frame = res.to_frame()
    assert list(frame.columns) == ["t_s", "x_0", "x_1", "sigma_x_0", "sigma_x_1"]
    np.testing.assert_array_equal(frame["x_1"], res.x[:, 1])
    innov = res.innovations_frame()
    assert len(innov) == len(z_d) and innov["accepted"].all()
    np.testing.assert_array_equal(innov["t_s"], [e.t for e in epochs])


def test_streaming_in_chunks_equals_one_run(tracking_system, rng):
    """Reference: the same run in one piece (the chunking must not change anything)."""
    model, samples, epochs, _, _ = _scenario(tracking_system, rng)
    x0, P0 = np.zeros(2), np.eye(2)
    filt = CdFilter(model, FilterConfig(store_every=3))
    whole = filt.run(samples, epochs, x0=x0, P0=P0)
    shaped = samples.shaped(0, 0, 1, 2)
    bounds = [0, 7, 25, 26, 120, STEPS + 1]  # includes a chunk ending on an epoch
    chunks = [shaped.slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]
    parts = list(filt.stream(chunks, epochs, x0=x0, P0=P0))
    np.testing.assert_allclose(parts[-1].x_final, whole.x_final, rtol=1e-13)
    np.testing.assert_allclose(np.concatenate([p.x for p in parts]), whole.x, rtol=1e-13)
    np.testing.assert_array_equal(np.concatenate([p.t for p in parts]), whole.t)
    assert sum(p.t_d.size for p in parts) == len(epochs)
    np.testing.assert_array_equal(whole.t, samples.t[:STEPS:3])
    joined = concatenate_results(parts)   # reference: the one-piece run again
    for name in ("t", "x", "P_diag", "t_d", "nis_d", "innov_d", "epoch_of", "accepted"):
        np.testing.assert_allclose(getattr(joined, name), getattr(whole, name), rtol=1e-13)
    assert joined.nis_c_count == whole.nis_c_count
    assert joined.n_steps == whole.n_steps == STEPS   # every step counted, stored or not


def test_manual_propagate_and_update_equal_run(tracking_system, rng):
    """Reference: run() over the same samples and epochs."""
    model, samples, epochs, _, _ = _scenario(tracking_system, rng)
    filt = CdFilter(model)
    x0, P0 = np.zeros(2), np.eye(2)
    whole = filt.run(samples, epochs, x0=x0, P0=P0)
    filt.reset(x0, P0)
    shaped = samples.shaped(0, 0, 1, 2)
    start = 0
    for epoch in epochs:
        k = int(round(epoch.t / DT))
        filt.propagate(shaped.slice(start, k + 1))
        filt.update(epoch.observations)
        start = k + 1
    np.testing.assert_allclose(filt.x, whole.x_final, rtol=1e-13)
    np.testing.assert_allclose(filt.P, whole.P_final, rtol=1e-13)


def test_callable_observations_see_the_prior_at_their_epoch(tracking_system, rng):
    """Reference: the same run with the observations built in advance. A callable epoch
    is evaluated with the prior (x, P) at the epoch's own sample, which must equal the
    state the manual propagate/update loop holds there."""
    model, samples, epochs, _, _ = _scenario(tracking_system, rng)
    x0, P0 = np.zeros(2), np.eye(2)
    filt = CdFilter(model)
    whole = filt.run(samples, epochs, x0=x0, P0=P0)
    seen = []

    def lazy(epoch):
        def build(x, P):
            seen.append((epoch.t, x.copy(), P.copy()))
            return epoch.observations
        return Epoch(epoch.t, build)

    lazy_run = filt.run(samples, [lazy(e) for e in epochs], x0=x0, P0=P0)
    np.testing.assert_array_equal(lazy_run.x_final, whole.x_final)
    filt.reset(x0, P0)
    shaped = samples.shaped(0, 0, 1, 2)
    start = 0
    for (t_seen, x_seen, P_seen), epoch in zip(seen, epochs):
        k = int(round(epoch.t / DT))
        filt.propagate(shaped.slice(start, k + 1))
        assert t_seen == epoch.t
        np.testing.assert_allclose(x_seen, filt.x, rtol=1e-13)
        np.testing.assert_allclose(P_seen, filt.P, rtol=1e-13)
        filt.update(epoch.observations)
        start = k + 1
    assert len(seen) == len(epochs)


def test_epoch_off_the_sample_grid_is_refused(tracking_system, rng):
    model, samples, epochs, _, _ = _scenario(tracking_system, rng)
    bad = [Epoch(0.1234, epochs[0].observations)]
    with pytest.raises(ModelError, match="not a sample time"):
        CdFilter(model).run(samples, bad, x0=np.zeros(2), P0=np.eye(2))


def test_bad_inputs_are_refused(tracking_system):
    model = tracking_system.model("drv")
    filt = CdFilter(model)
    t = np.arange(5) * DT
    with pytest.raises(ModelError):
        filt.run(InputSeries(t=t[::-1], u=np.zeros((5, 0)), q_c=Q_C), [], x0=np.zeros(2),
                 P0=np.eye(2))
    with pytest.raises(ModelError):
        filt.run(InputSeries(t=t, u=np.zeros((5, 0)), q_c=[np.nan, 1.0]), [],
                 x0=np.zeros(2), P0=np.eye(2))
    with pytest.raises(ModelError):
        filt.run(InputSeries(t=t, u=np.zeros((5, 0)), q_c=Q_C), [], x0=np.zeros(3),
                 P0=np.eye(2))


def test_jump_covariance_is_added_to_the_prior_before_the_update(tracking_system, rng):
    """Reference: the manual propagate/update loop with ``P += Q_jump`` done by hand at the
    second epoch (and the textbook Kalman update of that epoch written out here)."""
    from ekf.series import EpochRows
    model, samples, epochs, _, z_d = _scenario(tracking_system, rng)
    x0, P0 = np.zeros(2), np.eye(2)
    jump = np.diag([4.0, 0.0])   # a step of the first state, σ 2
    jumped = [Epoch(e.t, (lambda obs: (lambda x, P: EpochRows(obs, jump)))(e.observations))
              if i == 1 else e for i, e in enumerate(epochs)]
    filt = CdFilter(model)
    res = filt.run(samples, jumped, x0=x0, P0=P0)
    filt.reset(x0, P0)
    shaped = samples.shaped(0, 0, 1, 2)
    start = 0
    for i, epoch in enumerate(epochs):
        k = int(round(epoch.t / DT))
        filt.propagate(shaped.slice(start, k + 1))
        if i == 1:
            H = np.array([[1.0, 0.0]])
            P = filt.P + jump
            S = H @ P @ H.T + R_POS
            K = P @ H.T / S
            x_ref = filt.x + (K * (z_d[k] - filt.x[0])).ravel()
            P_ref = (np.eye(2) - K @ H) @ P
            filt.P = P
        filt.update(epoch.observations)
        if i == 1:
            np.testing.assert_allclose(filt.x, x_ref, rtol=1e-12)
            np.testing.assert_allclose(filt.P, P_ref, rtol=1e-12)
        start = k + 1
    np.testing.assert_allclose(res.x_final, filt.x, rtol=1e-12)
    np.testing.assert_allclose(res.P_final, filt.P, rtol=1e-12)


def test_bad_jump_covariance_is_refused(tracking_system, rng):
    from ekf.series import EpochRows
    with pytest.raises(ModelError, match="symmetric"):
        EpochRows([], np.array([[1.0, 0.5], [0.0, 1.0]]))
    with pytest.raises(ModelError, match="symmetric"):
        EpochRows([], np.diag([-1.0, 0.0]))
    model, samples, epochs, _, _ = _scenario(tracking_system, rng)
    bad = [Epoch(epochs[0].t, lambda x, P: EpochRows([], np.eye(3)))]
    with pytest.raises(ModelError, match="jump_covariance has shape"):
        CdFilter(model).run(samples, bad, x0=np.zeros(2), P0=np.eye(2))


@pytest.mark.parametrize("P0, words", [
    (np.array([[1.0, 2.0], [2.0, 1.0]]), "positive definiteness"),   # eigenvalues 3, -1
    (np.array([[1.0, 0.0], [0.0, 0.0]]), "positive definiteness"),   # singular
    (np.array([[1.0, 0.0], [0.0, np.nan]]), "non-finite")])
def test_a_covariance_that_is_not_positive_definite_is_refused(tracking_system, P0, words):
    """Edge table (closed form: the eigenvalues of each P0 are in its comment)."""
    from ekf.errors import FilterDivergedError
    filt = CdFilter(tracking_system.model("drv"))
    with pytest.raises(FilterDivergedError, match=words):
        filt.reset(np.zeros(2), P0)
    filt.reset(np.zeros(2), np.diag([1.0, 1e-12]))          # tiny but positive: accepted


@pytest.mark.parametrize("n_lin", [0, 3])
def test_joined_step_data_is_that_of_the_concatenated_samples(rng, n_lin):
    """Reference: `step_data` of the previous chunk's last sample and the new chunk
    concatenated (`_concat`, the engine's path before), compared bit for bit."""
    data = StepData(n_u=3, n_p=2, n_c=1, n_w=2, n_lin=n_lin,
                    jacobian_window_s=0.5 if n_lin else 0.0)

    def shaped(t):
        m = t.size
        return InputSeries(t=t, u=rng.normal(size=(m, 3)), q_c=rng.uniform(size=(m, 2)),
                           p=rng.normal(size=(m, 2)), z_c=rng.normal(size=(m, 1)),
                           r_c=rng.uniform(size=(m, 1)),
                           u_lin=rng.normal(size=(m, 3)) if n_lin else None)

    last = shaped(np.array([0.3]))
    chunk = shaped(0.3 + np.cumsum(rng.uniform(0.005, 0.02, 9)))
    t, d = _joined_step_data(data, last, chunk)
    joined = _concat(last, chunk)
    reference = step_data(SimpleNamespace(data=data), joined)
    assert d.shape == reference.shape == (9, data.size)
    np.testing.assert_array_equal(t.view(np.int64), joined.t.view(np.int64))
    np.testing.assert_array_equal(d.view(np.int64), reference.view(np.int64))
    if n_lin:          # a chunk without u_lin: the medians are computed from the samples
        no_lin = InputSeries(**{**chunk.__dict__, "u_lin": None})
        assert _joined_step_data(data, last, no_lin) is None
