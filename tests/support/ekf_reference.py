"""A pure-NumPy implementation of the same per-step algorithm as :mod:`ekf.step`.

It exists for two uses: the tests check the CasADi/compiled path against it, and the
benchmark times it as "a plain NumPy EKF loop" of the same dimensions; so it lives with
the tests' support code, not in the shipped `ekf` package. The model is
given as plain NumPy callables (:class:`NumpyModel`), so nothing here touches CasADi.
The equations are those of :mod:`ekf.step` (read its docstring); the RK4 transition is
the exact Jacobian of the RK4 map, by the chain rule through the four stages.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from ekf.step import StepOptions

__all__ = ["NumpyModel", "reference_step"]

Array = npt.NDArray[np.float64]
Fn = Callable[[Array, Array, Array], Array]


@dataclass(frozen=True)
class NumpyModel:
    """A process model as NumPy callables of ``(x (n,), u (n_u,), p (n_p,))``.

    Attributes
    ----------
    f : callable -> ndarray (n,)
    F_x : callable -> ndarray (n, n)
        ``∂f/∂x``.
    G : callable -> ndarray (n, n_w)
    h_c, H_c, D : callable or None
        Continuous measurement ``(n_c,)``, its Jacobian ``(n_c, n)``, noise map ``(n_c, n_w)``.
    """

    f: Fn
    F_x: Fn
    G: Fn
    h_c: Fn | None = None
    H_c: Fn | None = None
    D: Fn | None = None


def _rk4_with_jacobian(m: NumpyModel, x: Array, u0: Array, u1: Array, p: Array, dt: float,
                       opts: StepOptions) -> tuple[Array, Array]:
    u_mid = u0 if opts.input_hold == "zoh" else 0.5 * (u0 + u1)
    u_end = u0 if opts.input_hold == "zoh" else u1
    eye = np.eye(x.size)
    k1 = m.f(x, u0, p)
    x2 = x + 0.5 * dt * k1
    k2 = m.f(x2, u_mid, p)
    x3 = x + 0.5 * dt * k2
    k3 = m.f(x3, u_mid, p)
    x4 = x + dt * k3
    k4 = m.f(x4, u_end, p)
    x_next = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    if opts.transition == "taylor2":
        F = m.F_x(x, u0, p)
        return x_next, eye + F * dt + F @ F * (0.5 * dt * dt)
    d1 = m.F_x(x, u0, p)
    d2 = m.F_x(x2, u_mid, p) @ (eye + 0.5 * dt * d1)
    d3 = m.F_x(x3, u_mid, p) @ (eye + 0.5 * dt * d2)
    d4 = m.F_x(x4, u_end, p) @ (eye + dt * d3)
    return x_next, eye + dt / 6.0 * (d1 + 2.0 * d2 + 2.0 * d3 + d4)


def reference_step(m: NumpyModel, x: Array, P: Array, u0: Array, u1: Array, p: Array, *,
                   z_c: Array, dt: float, q_c: Array, r_c: Array,
                   opts: StepOptions = StepOptions(),
                   u_lin: Array | None = None) -> dict[str, Array]:
    """One step of the continuous–discrete filter, in NumPy.

    Parameters
    ----------
    m : NumpyModel
    x : ndarray, shape (n,)
        Prior at ``t_k``.
    P : ndarray, shape (n, n)
    u0, u1 : ndarray, shape (n_u,)
        Input samples at ``t_k`` and ``t_{k+1}``.
    p : ndarray, shape (n_p,)
    z_c : ndarray, shape (n_c,)
    dt : float
        Step, s.
    q_c : ndarray, shape (n_w,)
        Diagonal process-noise spectral density.
    r_c : ndarray, shape (n_c,)
        Diagonal independent continuous-measurement noise density.
    opts : StepOptions
    u_lin : ndarray, shape (n_u,), optional
        Input at which ``H = ∂h_c/∂x`` is evaluated (default `u0`; ``h_c`` and ``D`` are
        always at `u0`).

    Returns
    -------
    dict
        ``x_next (n,), P_next (n, n), x_filt, P_filt, innov (n_c,), S (n_c, n_c),
        nis (float), Phi (n, n)`` — the outputs of :func:`ekf.step.build_step`
        with the covariances unpacked.
    """
    n = x.size
    eye = np.eye(n)
    out: dict[str, Array] = {}
    x_filt, P_filt = x, P
    if m.h_c is not None:
        h = m.h_c(x, u0, p)
        H = m.H_c(x, u0 if u_lin is None else u_lin, p)
        D = m.D(x, u0, p)
        S_c = (D * q_c) @ D.T + np.diag(r_c)
        R = S_c / dt
        S = H @ P @ H.T + R
        factor = sla.cho_factor(S, lower=True)
        innov = z_c - h
        K = sla.cho_solve(factor, H @ P).T
        A = eye - K @ H
        P_filt = A @ P @ A.T + K @ R @ K.T
        x_filt = x + K @ innov
        out.update(innov=innov, S=S, nis=float(innov @ sla.cho_solve(factor, innov)))
    x_pred, Phi = _rk4_with_jacobian(m, x_filt, u0, u1, p, dt, opts)
    u_mean = u0 if opts.input_hold == "zoh" else 0.5 * (u0 + u1)
    G_bar = 0.5 * (eye + Phi) @ m.G(x_filt, u_mean, p)
    if m.h_c is not None:
        J_rate = sla.cho_solve(sla.cho_factor(S_c, lower=True), (D * q_c) @ G_bar.T).T
        x_next = x_pred + dt * J_rate @ (innov - H @ (K @ innov))
        Phi = Phi - dt * J_rate @ H
        B = (G_bar - J_rate @ D) * np.sqrt(q_c)
        B_c = J_rate * np.sqrt(r_c)
        Q = dt * (B @ B.T + B_c @ B_c.T)
    else:
        x_next = x_pred
        B = G_bar * np.sqrt(q_c)
        Q = dt * B @ B.T
    P_next = Phi @ P_filt @ Phi.T + Q
    out.update(x_next=x_next, P_next=0.5 * (P_next + P_next.T), x_filt=x_filt,
               P_filt=0.5 * (P_filt + P_filt.T), Phi=Phi)
    return out
