"""SEEDS.md erratum 9: with the paper's accelerometer noise (1e-10 m²/s³) and a large
initial covariance, RK4 of the continuous Riccati equation at Δt = 0.01 s blows up.
The engine's per-sample form must stay symmetric positive definite and converge to the
exact continuous solution.

Toy: state [tilt θ (rad), s (m), v (m/s)], v' = g θ + w_a, s' = v, θ' = c v; continuous
pseudo-measurement z = g θ + κ w_a (the same accelerometer noise: correlated). With a
single noise input the decorrelated process noise vanishes, so the inverse covariance
obeys the LINEAR equation Ẏ = −Y Ã − Ãᵀ Y + Hᵀ R⁻¹ H, solved exactly with a block
matrix exponential (Van Loan) — an independent reference.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ekf.packing import pack_sym, unpack_sym
from ekf.propagate import Propagator
from ekf.step import StepData

GRAVITY = 9.81  # m/s²
Q_ACCEL = 1e-10  # (m/s²)²·s, paper 2017
KAPPA = 0.5  # share of the accelerometer noise in the pseudo-measurement
CURVATURE = 0.05  # 1/m: couples the observed tilt to the speed (θ' = c v)
P0 = np.diag([1.0, 1e6, 1e2])  # rad², m², (m/s)²: "large initial covariance"
DT = 0.01  # s
HORIZON = 2.0  # s


def _system(linear_system):
    A = np.array([[0.0, 0.0, CURVATURE], [0.0, 0.0, 1.0], [GRAVITY, 0.0, 0.0]])
    G = np.array([[0.0], [0.0], [1.0]])
    H = np.array([[GRAVITY, 0.0, 0.0]])
    D = np.array([[KAPPA]])
    return linear_system(A=A, G=G, H=H, D=D)


def _exact_covariance(sys_, t: float) -> np.ndarray:
    """P(t) of the continuous Riccati equation from the linear information equation."""
    r = Q_ACCEL * KAPPA ** 2
    A_t = sys_.A - sys_.G * Q_ACCEL * KAPPA / r @ sys_.H
    W = sys_.H.T @ sys_.H / r
    scale = np.linalg.norm(W)
    n = A_t.shape[0]
    block = np.block([[A_t.T, W / scale], [np.zeros((n, n)), -A_t]]) * t
    E = sla.expm(block)
    integral = E[n:, n:].T @ E[:n, n:] * scale
    E_a = sla.expm(-A_t * t)
    Y = E_a.T @ np.linalg.inv(P0) @ E_a + integral
    Y = 0.5 * (Y + Y.T)
    equil = 1.0 / np.sqrt(np.diag(Y))  # Y spans 19 decades: invert it equilibrated
    P = equil[:, None] * np.linalg.inv(equil[:, None] * Y * equil[None, :]) * equil[None, :]
    return 0.5 * (P + P.T)


def _naive_riccati_rk4(sys_, dt: float, steps: int) -> np.ndarray:
    """RK4 of Ṗ = AP + PAᵀ + GQGᵀ − (PHᵀ + GQDᵀ)(DQDᵀ)⁻¹(PHᵀ + GQDᵀ)ᵀ."""
    A, G, H, D = sys_.A, sys_.G, sys_.H, sys_.D
    Q = np.array([[Q_ACCEL]])
    R_inv = np.linalg.inv(D @ Q @ D.T)

    def rhs(P):
        gain = P @ H.T + G @ Q @ D.T
        return A @ P + P @ A.T + G @ Q @ G.T - gain @ R_inv @ gain.T

    P = P0.copy()
    with np.errstate(all="ignore"):
        for _ in range(steps):
            k1 = rhs(P)
            k2 = rhs(P + 0.5 * dt * k1)
            k3 = rhs(P + 0.5 * dt * k2)
            k4 = rhs(P + dt * k3)
            P = P + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return P


def _engine_covariance(sys_, dt: float) -> np.ndarray:
    model = sys_.model(f"stiff{int(round(1 / dt))}")
    prop = Propagator(model, backend="compiled")
    steps = int(round(HORIZON / dt))
    d = StepData.of(model).assemble(np.zeros((steps + 1, 0)), np.zeros((steps, 0)),
                                    np.zeros((steps, 1)), np.full(steps, dt),
                                    np.full((steps, 1), Q_ACCEL), np.zeros((steps, 1)))
    out = prop.run(np.zeros(3), pack_sym(P0), d)
    P_all = unpack_sym(out.P_next)
    for P in P_all:  # symmetric positive definite at every step
        np.linalg.cholesky(P)
    return P_all[-1]


def _relative_error(P, P_ref) -> float:
    """Largest error relative to the reference standard deviations."""
    scale = np.sqrt(np.outer(np.diag(P_ref), np.diag(P_ref)))
    return float(np.max(np.abs(P - P_ref) / scale))


def test_naive_riccati_rk4_blows_up(linear_system):
    P = _naive_riccati_rk4(_system(linear_system), DT, int(HORIZON / DT))
    finite = np.all(np.isfinite(P))
    assert not finite or np.min(np.linalg.eigvalsh(0.5 * (P + P.T))) < 0.0


def test_engine_stays_spd_and_converges_to_exact_solution(linear_system):
    """First-order convergence of the sampled form to the exact continuous covariance:
    the error at Δt must be below ‖Ã‖Δt (the first-order bound, constant 1) and shrink
    at least 1.8× per halving of Δt (order ≥ 0.85)."""
    sys_ = _system(linear_system)
    P_ref = _exact_covariance(sys_, HORIZON)
    errors = [_relative_error(_engine_covariance(sys_, dt), P_ref)
              for dt in (DT, DT / 2, DT / 4)]
    a_tilde = np.linalg.norm(sys_.A - sys_.G @ sys_.H / KAPPA, 2)
    assert errors[0] <= a_tilde * DT
    assert errors[0] / errors[1] >= 1.8 and errors[1] / errors[2] >= 1.8
