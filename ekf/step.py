"""The symbolic per-step function: RK4 propagation + the correlated continuous update.

One IMU step ``t_k → t_{k+1}`` (length ``dt``) is built as ONE CasADi SX function

``step(x[n], P[n(n+1)/2], d[k_d]) -> (x_next, P_next, x_filt, P_filt, innov, S, nis, Phi)``

with ``x, P`` the prior at ``t_k`` (given the continuous samples before ``k`` and every
discrete update up to ``t_k``), ``P`` packed (:mod:`ekf.packing`) and ``d`` the step data
(:class:`StepData`). It does, in order:

1. **Continuous measurement at t_k as a sampled measurement** (paper 2017 eq. 14; Simon,
   *Optimal State Estimation*, 2006, §7.1). Averaging ``z_c`` over the step gives
   ``z_k = h_c(x_k, u_k, p_k) + v_k`` with ``v_k = D ω̄ + v̄_c``, ``ω̄ = (1/dt)∫w``
   (covariance ``Qc/dt``), so ``R_k = (D Qc Dᵀ + Rc)/dt = S_c/dt``. Update (Joseph
   form, valid for any gain): ``K = P Hᵀ S⁻¹``, ``S = H P Hᵀ + R_k``,
   ``P_filt = (I − K H) P (I − K H)ᵀ + K R_k Kᵀ``. The innovation, ``S`` and
   ``NIS = νᵀ S⁻¹ ν`` (Cholesky, no inverse) are step outputs.
2. **Decorrelation.** The process noise of the step, ``w_k ≈ Ḡ ∫w``, with
   ``Ḡ = (I + Φ)/2 · G`` (≈ ``Φ(t_{k+1}, t_k + dt/2) G``: second order in ``dt``), is
   correlated with ``v_k``: ``M = E[w_k v_kᵀ] = Ḡ Qc Dᵀ``. Writing
   ``x_{k+1} = f_d(x_k) + J (z_k − h_c(x_k)) + (w_k − J v_k)`` with ``J = M R_k⁻¹ =
   dt · Ḡ Qc Dᵀ S_c⁻¹`` makes the new noise uncorrelated with ``v_k``, of covariance
   ``Q̃ = dt (B Qc Bᵀ + J_r Rc J_rᵀ)``, ``B = Ḡ − J_r D``, ``J_r = J/dt`` — a product,
   positive semi-definite by construction.
3. **Prediction**: ``x_next = RK4(x_filt) + J (I − H K) ν`` (``(I − H K) ν`` is
   ``z − h_c(x_filt)`` linearized), ``P_next = Φ̃ P_filt Φ̃ᵀ + Q̃``, ``Φ̃ = Φ − J H``.

Without a continuous measurement step 1 is skipped, ``J = 0`` and ``Q = dt Ḡ Qc Ḡᵀ``.

Every covariance is a sum of congruences ``A P Aᵀ`` and products ``B Bᵀ``: it stays
symmetric (only the lower triangle is output) and positive semi-definite whatever the
gain, which is what keeps the filter stable when ``R_k`` is ~1e-8 while ``P`` is ~1e6
(SEEDS.md erratum 9: RK4 of the continuous Riccati equation blows up there).

Input convention (:class:`StepOptions`): ``u_k`` and ``u_{k+1}`` are samples at the ends
of the step. ``input_hold="linear"`` interpolates them (RK4 stages use ``u_k``,
``(u_k+u_{k+1})/2`` twice, ``u_{k+1}``); ``"zoh"`` holds ``u_k`` over the step (exact
when ``u_k`` is the average of the input over the step, as IMU increments are). ``G`` is
evaluated at the mean input of the step, ``h_c`` and ``D`` at ``u_k``.
``transition="rk4"`` takes ``Φ`` as the exact Jacobian of the RK4 map;
``"taylor2"`` as ``I + F dt + F² dt²/2`` with ``F = ∂f/∂x`` at the start of the step.

Linearization input (``StepOptions.jacobian_window_s``): by default ``H = ∂h_c/∂x`` is
evaluated at ``u_k`` too. When ``h_c`` depends on a state through the input (the track
pseudo-observation's yaw, through the measured specific force, on a straight), ``H`` at
the raw, noisy sample has a spurious component of the size of the input noise, and the
update draws information about that state from noise at every step (``|H|²/R ≈ 1`` per
sample for the yaw of a tactical IMU). With ``jacobian_window_s > 0`` the step data
carries a second input, ``u_lin`` (:func:`window_median` of the samples over a centred
window of that length), and ``H`` (in the update, in ``Φ̃ = Φ − J H`` and in the
prediction's residual) is ``∂h_c/∂x`` at ``u_lin``, while the residual ``z_c − h_c`` and
``D`` stay at ``u_k``: ``h_c(x) ≈ h_c(x̂, u_k) + H(x̂, u_lin) (x − x̂)``.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Literal

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.errors import ModelError
from ekf.model import CdModel
from ekf.packing import pack_sym_sx, packed_size, unpack_sym_sx
from ekf.running_median import window_rows

__all__ = ["StepOptions", "StepData", "build_step", "window_median", "window_median_at",
           "STEP_OUTPUTS", "WINDOW_TOL_S"]

Array = npt.NDArray[np.float64]

#: Names of the outputs of the step function, in order.
STEP_OUTPUTS = ("x_next", "P_next", "x_filt", "P_filt", "innov", "S", "nis", "Phi")

#: Samples within this of a window's edge are inside it, s (time jitter of sample clocks).
WINDOW_TOL_S = 1e-9


@dataclass(frozen=True)
class StepOptions:
    """How one step is discretized.

    Attributes
    ----------
    input_hold : {"linear", "zoh"}
        Input between samples: linear interpolation or zero-order hold of ``u_k``.
    transition : {"rk4", "taylor2"}
        ``Φ`` as the Jacobian of the RK4 map, or ``I + F dt + F² dt²/2``.
    jacobian_window_s : float
        Length of the centred window, s, of the running median (:func:`window_median`) at
        which ``H = ∂h_c/∂x`` is evaluated (module docstring). 0 (default): at ``u_k``,
        with no extra data column (the step function is the one without the option).
        Only used by models with a continuous measurement.
    """

    input_hold: Literal["linear", "zoh"] = "linear"
    transition: Literal["rk4", "taylor2"] = "rk4"
    jacobian_window_s: float = 0.0

    def __post_init__(self) -> None:
        if self.input_hold not in ("linear", "zoh"):
            raise ModelError(f"input_hold must be 'linear' or 'zoh', not {self.input_hold!r}")
        if self.transition not in ("rk4", "taylor2"):
            raise ModelError(f"transition must be 'rk4' or 'taylor2', not {self.transition!r}")
        if not (np.isfinite(self.jacobian_window_s) and self.jacobian_window_s >= 0.0):
            raise ModelError(f"jacobian_window_s must be finite and >= 0, not "
                             f"{self.jacobian_window_s!r}")


@dataclass(frozen=True)
class StepData:
    """Layout of the per-step data vector
    ``d = [u_k, u_{k+1}, p_k, z_c, dt, q_c, r_c, u_lin]``.

    Attributes
    ----------
    n_u, n_p, n_c, n_w : int
        Sizes of the input, parameter, continuous measurement and noise vectors.
    n_lin : int
        Size of ``u_lin``, the input at which ``H`` is evaluated (``n_u``), or 0 when ``H``
        is evaluated at ``u_k`` (no column: the layout without the option).
    jacobian_window_s : float
        The window of ``u_lin`` (:func:`window_median`), s (0 when ``n_lin`` is 0).
    """

    n_u: int
    n_p: int
    n_c: int
    n_w: int
    n_lin: int = 0
    jacobian_window_s: float = 0.0

    @classmethod
    def of(cls, model: CdModel, opts: "StepOptions" = StepOptions()) -> "StepData":
        """The step-data layout of a model under `opts` (``u_lin`` only for a model with a
        continuous measurement and ``opts.jacobian_window_s > 0``)."""
        lin = model.n_c > 0 and opts.jacobian_window_s > 0.0
        return cls(model.n_u, model.n_p, model.n_c, model.n_w, model.n_u if lin else 0,
                   float(opts.jacobian_window_s) if lin else 0.0)

    @property
    def size(self) -> int:
        """Length ``k_d`` of one step's data vector."""
        return 2 * self.n_u + self.n_p + 2 * self.n_c + 1 + self.n_w + self.n_lin

    def split(self, d: ca.SX) -> tuple[ca.SX, ...]:
        """Symbolic ``(u0, u1, p, z_c, dt, q_c, r_c, u_lin)`` of a data vector (``u_lin``
        is ``u0`` when ``n_lin`` is 0)."""
        sizes = (self.n_u, self.n_u, self.n_p, self.n_c, 1, self.n_w, self.n_c, self.n_lin)
        offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        parts = tuple(d[int(a):int(b)] for a, b in zip(offsets[:-1], offsets[1:]))
        return parts if self.n_lin else parts[:-1] + (parts[0],)

    def assemble(self, u: Array, p: Array, z_c: Array, dt: Array, q_c: Array,
                 r_c: Array, *, t: Array | None = None, u_lin: Array | None = None
                 ) -> Array:
        """Data rows for ``N`` steps from ``N + 1`` input samples (of ``K`` members
        at once when every argument has a leading member axis, ``(K, ...)``).

        Parameters
        ----------
        u : ndarray, shape (N + 1, n_u)
            Input samples at ``t_0 .. t_N``.
        p : ndarray, shape (N, n_p)
        z_c : ndarray, shape (N, n_c)
            Continuous-measurement values (usually zeros).
        dt : ndarray, shape (N,)
            Step lengths, s (> 0).
        q_c : ndarray, shape (N, n_w)
            Diagonal of the process-noise spectral density, [w]²·s.
        r_c : ndarray, shape (N, n_c)
            Diagonal of the independent continuous-measurement noise density, [z]²·s.
        t : ndarray, shape (N + 1,), optional
            Sample times, s (increasing); needed when ``n_lin > 0``: ``u_lin`` of step
            ``k`` is :func:`window_median` of these ``N + 1`` samples at ``t_k`` (one
            member only).
        u_lin : ndarray, shape (N + 1, n_u), optional
            The linearization input of each sample, given (instead of computed from `t`
            and `u`); its first ``N`` rows are used.

        Returns
        -------
        ndarray, shape (N, k_d)
            (``(K, N, k_d)`` for ``K`` members.)
        """
        parts = [u[..., :-1, :], u[..., 1:, :], p, z_c, dt[..., None], q_c, r_c]
        if self.n_lin and u_lin is not None:
            parts.append(np.asarray(u_lin, dtype=float)[..., :-1, :])
        elif self.n_lin:
            if t is None:
                raise ModelError("step data with a linearization window need the sample "
                                 "times t")
            parts.append(window_median(t, u, self.jacobian_window_s)[:-1])
        return np.concatenate(parts, axis=-1)


def window_median(t: Array, u: Array, window_s: float) -> Array:
    """Running median of samples over a centred window.

    Row ``k`` of the result is the median (per column; the mean of the two middle values
    for an even count, as `numpy.median`) of the rows ``u_j`` with
    ``|t_j − t_k| <= h_k``, ``h_k = min(window_s / 2, t_k − t_0, t_{M−1} − t_k)``
    (within `WINDOW_TOL_S`). The window stays centred on ``t_k``: near the ends of the
    series it shrinks (to the sample alone at the first and the last) instead of turning
    one-sided. A centred median keeps a step of the input at its sample (a curve entered
    without a transition: the lateral force and the yaw rate step); a window cut to one
    side puts the step up to a quarter window late or early (measured: 100 m/s on a
    100-m circle, seeds 1–3, NEES mean 13.5 at the raw samples, 15.1 with one-sided
    ends, 13.45 centred). A series processed in chunks sees each chunk's ends through
    shrunken windows (`ekf.cd_filter.step_data`) unless the driver gives each chunk the
    median of the whole series (`ekf.series.InputSeries.u_lin`).

    The windows' bounds are found in NumPy, their medians by `ekf.running_median`
    (a compiled kernel that slides a sorted window; a NumPy sort without a compiler).

    Parameters
    ----------
    t : ndarray, shape (M,)
        Sample times, s, increasing.
    u : ndarray, shape (M, n_u)
        Samples (finite).
    window_s : float
        Window length, s (>= 0; 0: each sample alone).

    Returns
    -------
    ndarray, shape (M, n_u)
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    if t.ndim != 1 or u.ndim != 2 or u.shape[0] != t.size:
        raise ModelError(f"window_median needs t (M,) and u (M, n_u); got {t.shape}, "
                         f"{u.shape}")
    if not window_s >= 0.0:
        raise ModelError(f"window_s must be >= 0, got {window_s!r}")
    if t.size == 0:
        return u.copy()
    half = np.minimum(0.5 * window_s, np.minimum(t - t[0], t[-1] - t)) + WINDOW_TOL_S
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right")
    return window_rows(u, lo, hi)


def window_median_at(t: Array, u: Array, start: int, stop: int, window_s: float) -> Array:
    """Rows ``start:stop`` of ``window_median(t, u, window_s)``, computed from the samples
    within reach of them only (one more on each side, so that every window is the whole
    series' one, to the bit): a chunk's rows without a pass over the whole series.

    Parameters
    ----------
    t : ndarray, shape (M,)
    u : ndarray, shape (M, n_u)
    start, stop : int
        ``0 <= start < stop <= M``.
    window_s : float

    Returns
    -------
    ndarray, shape (stop - start, n_u)
    """
    half = 0.5 * window_s + WINDOW_TOL_S
    lo = max(int(np.searchsorted(t, t[start] - half, side="left")) - 1, 0)
    hi = min(int(np.searchsorted(t, t[stop - 1] + half, side="right")) + 1, t.size)
    return window_median(t[lo:hi], u[lo:hi], window_s)[start - lo:stop - lo]


def _rk4(model: CdModel, x: ca.SX, u0: ca.SX, u1: ca.SX, p: ca.SX, dt: ca.SX,
         hold: str) -> ca.SX:
    u_mid = u0 if hold == "zoh" else 0.5 * (u0 + u1)
    u_end = u0 if hold == "zoh" else u1
    k1 = model.f(x, u0, p)
    k2 = model.f(x + 0.5 * dt * k1, u_mid, p)
    k3 = model.f(x + 0.5 * dt * k2, u_mid, p)
    k4 = model.f(x + dt * k3, u_end, p)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def _propagator(model: CdModel, opts: StepOptions) -> ca.Function:
    """``(x, u0, u1, p, dt) -> (x_next, Phi, G_mid)`` for the chosen options."""
    n, n_u, n_p = model.n, model.n_u, model.n_p
    x, u0, u1 = ca.SX.sym("x", n), ca.SX.sym("u0", n_u), ca.SX.sym("u1", n_u)
    p, dt = ca.SX.sym("p", n_p), ca.SX.sym("dt")
    x_next = _rk4(model, x, u0, u1, p, dt, opts.input_hold)
    u_mean = u0 if opts.input_hold == "zoh" else 0.5 * (u0 + u1)
    if opts.transition == "rk4":
        Phi = ca.jacobian(x_next, x)
    else:
        F = ca.jacobian(model.f(x, u0, p), x)
        Phi = ca.SX.eye(n) + F * dt + ca.mtimes(F, F) * (0.5 * dt * dt)
    return ca.Function("propagate", [x, u0, u1, p, dt],
                       [x_next, ca.densify(Phi), model.G(x, u_mean, p)])


def _chol_lower(S: ca.SX) -> ca.SX:
    """Lower Cholesky factor of a small symbolic SPD matrix."""
    return ca.chol(S).T


def _solve_lower(L: ca.SX, B: ca.SX) -> ca.SX:
    """``L⁻¹ B`` for lower-triangular ``L`` by forward substitution (small sizes)."""
    rows = []
    for i in range(L.shape[0]):
        acc = B[i, :]
        for j, row in enumerate(rows):
            acc = acc - L[i, j] * row
        rows.append(acc / L[i, i])
    return ca.vertcat(*rows)


def _spd_solve(L: ca.SX, B: ca.SX) -> ca.SX:
    """``S⁻¹ B`` with ``S = L Lᵀ``: two triangular solves, no inverse."""
    Y = _solve_lower(L, B)
    # back substitution with Lᵀ, written as a forward solve on the reversed system
    n = L.shape[0]
    rev = list(range(n - 1, -1, -1))
    U_rev = L.T[rev, rev]
    return _solve_lower(U_rev, Y[rev, :])[rev, :]


@functools.lru_cache(maxsize=16)
def build_step(model: CdModel, opts: StepOptions = StepOptions()) -> ca.Function:
    """Build the per-step SX function of a model (see the module docstring).

    Built once per model object and options (a model is immutable; the filters' process
    models are themselves built once per configuration, so a second run in a process,
    a study's or a bank's, does not build its step again: ~20 ms).

    Parameters
    ----------
    model : CdModel
    opts : StepOptions

    Returns
    -------
    casadi.Function
        ``(x[n], P[n(n+1)/2], d[k_d]) -> (x_next[n], P_next[n(n+1)/2], x_filt[n],
        P_filt[n(n+1)/2], innov[n_c], S[n_c(n_c+1)/2], nis[1 or 0], Phi[n*n])``;
        ``Phi`` is ``Φ̃`` row by row (``Phi.reshape(n, n)`` in NumPy).
    """
    n, n_c = model.n, model.n_c
    data = StepData.of(model, opts)
    x, P_packed, d = ca.SX.sym("x", n), ca.SX.sym("P", packed_size(n)), ca.SX.sym("d", data.size)
    u0, u1, p, z_c, dt, q_c, r_c, u_lin = data.split(d)
    P = unpack_sym_sx(P_packed, n)
    eye = ca.SX.eye(n)
    x_filt, P_filt = x, P
    innov, S_out, nis = ca.SX(0, 1), ca.SX(0, 1), ca.SX(0, 1)
    if n_c:
        h = model.h_c(x, u0, p)
        H = ca.densify(ca.jacobian(model.h_c(x, u_lin, p) if data.n_lin else h, x))
        D = model.D(x, u0, p)
        S_c = ca.mtimes([D, ca.diag(q_c), D.T]) + ca.diag(r_c)
        R = S_c / dt
        S = ca.mtimes([H, P, H.T]) + R
        L = _chol_lower(S)
        innov = z_c - h
        K = _spd_solve(L, ca.mtimes(H, P)).T
        A = eye - ca.mtimes(K, H)
        P_filt = ca.mtimes([A, P, A.T]) + ca.mtimes([K, R, K.T])
        x_filt = x + ca.mtimes(K, innov)
        white = _solve_lower(L, innov)
        nis = ca.dot(white, white)
        S_out = pack_sym_sx(S)
    x_pred, Phi, G = _propagator(model, opts)(x_filt, u0, u1, p, dt)
    G_bar = 0.5 * ca.mtimes(eye + Phi, G)
    if n_c:
        L_c = _chol_lower(S_c)
        J_rate = _spd_solve(L_c, ca.mtimes([D, ca.diag(q_c), G_bar.T])).T
        residual = innov - ca.mtimes(H, ca.mtimes(K, innov))
        x_next = x_pred + dt * ca.mtimes(J_rate, residual)
        Phi = Phi - dt * ca.mtimes(J_rate, H)
        B = ca.mtimes(G_bar - ca.mtimes(J_rate, D), ca.diag(ca.sqrt(q_c)))
        B_c = ca.mtimes(J_rate, ca.diag(ca.sqrt(r_c)))
        Q = dt * (ca.mtimes(B, B.T) + ca.mtimes(B_c, B_c.T))
    else:
        x_next = x_pred
        B = ca.mtimes(G_bar, ca.diag(ca.sqrt(q_c)))
        Q = dt * ca.mtimes(B, B.T)
    P_next = ca.mtimes([Phi, P_filt, Phi.T]) + Q
    outputs = [x_next, pack_sym_sx(P_next), x_filt, pack_sym_sx(P_filt), innov, S_out,
               nis, ca.vec(Phi.T)]
    return ca.Function(f"{model.name}_step", [x, P_packed, d], outputs,
                       ["x", "P", "d"], list(STEP_OUTPUTS))
