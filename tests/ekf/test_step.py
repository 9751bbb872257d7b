"""The per-step function (ekf/step.py) against independent references: a NumPy
implementation with hand-written Jacobians, the textbook one-step predictor with
correlated noise (Simon 2006, §7.1), scipy's expm / Van Loan, and a fine-step Monte
Carlo simulation of the continuous-time problem."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from ekf.packing import pack_sym, unpack_sym
from ekf.propagate import Propagator
from ekf.step import StepData, StepOptions
from tests.support.ekf_examples import attitude_speed_clock_numpy, attitude_speed_clock_toy
from tests.support.ekf_reference import reference_step


#: Relative agreement of two implementations of the same floating-point algorithm
#: (different operation order; 200 steps of ~1e3 flops each).
RTOL_SAME_ALGORITHM = 1e-10
#: Paper accelerometer noise density, (m/s²)²·s (SEEDS.md §1), and a gyro density.
Q_ACCEL = 1e-10
Q_GYRO = 1e-12
DT = 0.01  # s, the paper's 100 Hz IMU step


def _toy_data(rng, n_steps: int) -> dict:
    u = np.zeros((n_steps + 1, 6))
    u[:, 2] = 9.81
    u[:, 3:] = rng.normal(0.0, 0.02, (n_steps + 1, 3))
    u[:, :3] += rng.normal(0.0, 0.05, (n_steps + 1, 3))
    return dict(u=u, p=np.zeros((n_steps, 0)), z_c=rng.normal(0, 1e-3, (n_steps, 2)),
                dt=np.full(n_steps, DT),
                q_c=np.tile([Q_ACCEL] * 3 + [Q_GYRO] * 3, (n_steps, 1)),
                r_c=np.full((n_steps, 2), 1e-6))


@pytest.mark.parametrize("backend", ["compiled", "casadi"])
@pytest.mark.parametrize("hold,transition", [("linear", "rk4"), ("zoh", "taylor2")])
def test_step_matches_numpy_reference_on_toy(rng, backend, hold, transition):
    """Reference: tests/support/ekf_reference.py with the toy's hand-written NumPy Jacobians."""
    n_steps = 200
    opts = StepOptions(input_hold=hold, transition=transition)
    prop = Propagator(attitude_speed_clock_toy(), opts, backend=backend)
    data = _toy_data(rng, n_steps)
    d = StepData.of(attitude_speed_clock_toy()).assemble(**data)
    u = data["u"]
    x0 = np.array([0.5, 0.01, -0.02, 0.0, 20.0, 100.0, 1.0])
    P0 = np.diag([1.0, 0.1, 0.1, 1e6, 1.0, 1e6, 1.0])
    out = prop.run(x0, pack_sym(P0), d)
    model_np, x, P = attitude_speed_clock_numpy(), x0, P0
    for k in range(n_steps):
        ref = reference_step(model_np, x, P, u[k], u[k + 1], np.zeros(0), z_c=data["z_c"][k],
                             dt=DT, q_c=data["q_c"][k], r_c=data["r_c"][k], opts=opts)
        x, P = ref["x_next"], ref["P_next"]
    scale = np.sqrt(np.outer(np.diag(P), np.diag(P)))
    np.testing.assert_allclose(out.x_next[-1], x, rtol=RTOL_SAME_ALGORITHM, atol=1e-12)
    assert np.all(np.abs(unpack_sym(out.P_next[-1]) - P) <= RTOL_SAME_ALGORITHM * scale)
    np.testing.assert_allclose(out.nis[-1], ref["nis"], rtol=RTOL_SAME_ALGORITHM)
    np.testing.assert_allclose(out.Phi[-1].reshape(7, 7), ref["Phi"],
                               rtol=RTOL_SAME_ALGORITHM, atol=1e-14)


def test_correlated_step_equals_textbook_one_step_predictor(tracking_system, rng):
    """Reference: the one-step predictor with correlated noise, written with explicit
    inverses (Simon 2006, eqs. 7.14–7.16): K = (Φ P Hᵀ + M)(H P Hᵀ + R)⁻¹,
    x⁺ = Φ x + K (z − H x), P⁺ = Φ P Φᵀ + Q − K (H P Hᵀ + R) Kᵀ."""
    sys_ = tracking_system
    q_c, r_c = np.array([0.7, 0.2]), np.array([0.05])
    prop = Propagator(sys_.model("corr"), backend="compiled")
    x = rng.normal(size=2)
    A = rng.normal(size=(2, 2))
    P = A @ A.T + np.eye(2)
    z = rng.normal(size=1)
    d = StepData.of(sys_.model("corr")).assemble(np.zeros((2, 0)), np.zeros((1, 0)), z[None],
                                                   np.array([DT]), q_c[None], r_c[None])
    out = prop.run(x, pack_sym(P), d)
    m = sys_.discrete(DT, q_c, r_c)
    Phi, Q, R, M, H = m["Phi"], m["Q"], m["R"], m["M"], sys_.H
    S = H @ P @ H.T + R
    K = (Phi @ P @ H.T + M) @ np.linalg.inv(S)
    x_ref = Phi @ x + K @ (z - H @ x)
    P_ref = Phi @ P @ Phi.T + Q - K @ S @ K.T
    np.testing.assert_allclose(out.x_next[0], x_ref, rtol=RTOL_SAME_ALGORITHM)
    np.testing.assert_allclose(unpack_sym(out.P_next[0]), P_ref, rtol=RTOL_SAME_ALGORITHM)


def test_transition_and_noise_against_expm_and_van_loan(linear_system):
    """Reference: Φ = expm(A dt) and Van Loan's Q = ∫ e^{As} G Qc Gᵀ e^{Aᵀs} ds (scipy)."""
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-2.0, -1.5, -0.8]])
    G = np.array([[0.0], [0.3], [1.0]])
    q_c = np.array([0.4])
    sys_ = linear_system(A=A, G=G)
    prop = Propagator(sys_.model("vanloan"), backend="compiled")
    data = StepData.of(sys_.model("vanloan"))
    for dt in (0.01, 0.05):
        d = data.assemble(np.zeros((2, 0)), np.zeros((1, 0)), np.zeros((1, 0)),
                          np.array([dt]), q_c[None], np.zeros((1, 0)))
        out = prop.run(np.zeros(3), np.zeros(6), d)
        Phi = out.Phi[0].reshape(3, 3)
        a_dt = np.linalg.norm(A, 2) * dt
        # RK4 = Taylor polynomial of order 4: the error is the order-5 remainder
        assert np.linalg.norm(Phi - sla.expm(A * dt), 2) <= a_dt ** 5 / 120 * np.exp(a_dt)
        block = np.block([[-A, G @ np.diag(q_c) @ G.T], [np.zeros((3, 3)), A.T]]) * dt
        E = sla.expm(block)
        Q_ref = E[3:, 3:].T @ E[:3, 3:]
        # Q with Ḡ = (I+Φ)/2 G is exact to second order: relative error O((|A| dt)²)
        err = np.linalg.norm(unpack_sym(out.P_next[0]) - Q_ref, 2) / np.linalg.norm(Q_ref, 2)
        assert err <= a_dt ** 2


def _simulate_fine(sys_, q_c, P0, runs, steps, substeps, rng):
    """Euler–Maruyama truth and the step-averaged continuous measurement z_k =
    (1/dt) ∫ (H x + D w) dt over each step."""
    n = sys_.A.shape[0]
    h = DT / substeps
    x = rng.multivariate_normal(np.zeros(n), P0, size=runs)
    z = np.zeros((runs, steps, sys_.H.shape[0]))
    for k in range(steps):
        acc = np.zeros((runs, sys_.H.shape[0]))
        for _ in range(substeps):
            dw = rng.normal(size=(runs, q_c.size)) * np.sqrt(q_c * h)
            acc += x @ sys_.H.T * h + dw @ sys_.D.T
            x = x + x @ sys_.A.T * h + dw @ sys_.G.T
        z[:, k] = acc / DT
    return x, z


def _mean_nees(sys_, q_c, r_c, P0, x_true, z) -> float:
    model = sys_.model(f"mc{abs(hash(sys_.D.tobytes())) % 10**8}")
    prop = Propagator(model, backend="compiled")
    data = StepData.of(model)
    runs, steps, _ = z.shape
    nees = np.zeros(runs)
    for r in range(runs):
        d = data.assemble(np.zeros((steps + 1, 0)), np.zeros((steps, 0)), z[r],
                          np.full(steps, DT), np.tile(q_c, (steps, 1)), np.tile(r_c, (steps, 1)))
        out = prop.run(np.zeros(2), pack_sym(P0), d)
        e = x_true[r] - out.x_next[-1]
        nees[r] = e @ np.linalg.solve(unpack_sym(out.P_next[-1]), e)
    return float(nees.mean())


def test_correlated_noise_factors_against_fine_step_monte_carlo(tracking_system, linear_system,
                                                                rng):
    """Reference: Monte Carlo of the continuous-time system (20 Euler–Maruyama substeps
    per sample). The mean NEES of 2000 runs after 50 steps must lie in its 99.9 % χ²
    band; the same filter with the noise correlation dropped must not (the test can
    fail when the cross-covariance M or its Δt factors are wrong)."""
    from scipy.stats import chi2
    runs, steps, q_c = 2000, 50, np.array([40.0, 10.0])
    P0 = np.diag([1.0, 4.0])
    x_true, z = _simulate_fine(tracking_system, q_c, P0, runs, steps, 20, rng)
    low, high = (chi2.ppf(p, 2 * runs) / runs for p in (0.0005, 0.9995))
    nees = _mean_nees(tracking_system, q_c, np.zeros(1), P0, x_true, z)
    assert low <= nees <= high
    D = tracking_system.D
    uncorrelated = linear_system(A=tracking_system.A, G=tracking_system.G, H=tracking_system.H,
                                D=np.zeros_like(D))
    r_equiv = np.diag(D @ np.diag(q_c) @ D.T)
    assert not low <= _mean_nees(uncorrelated, q_c, r_equiv, P0, x_true, z) <= high
