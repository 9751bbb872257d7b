"""Fixed-step Runge–Kutta 4 integration over IMU samples.

Sample convention (one owner, used by every integrator and filter of the project):
IMU samples are the **instantaneous** specific force and angular rate at the sample
times ``t_k = t_0 + k dt`` (not increments). The step ``t_k -> t_{k+1}`` evaluates the
model with ``u_k`` at the start, ``(u_k + u_{k+1})/2`` at the midpoint and ``u_{k+1}``
at the end::

    k1 = f(x_k,            u_k)
    k2 = f(x_k + dt/2 k1,  u_mid)
    k3 = f(x_k + dt/2 k2,  u_mid)
    k4 = f(x_k + dt k3,    u_{k+1})
    x_{k+1} = x_k + dt/6 (k1 + 2 k2 + 2 k3 + k4)

The linear interpolation of the input makes the scheme second-order in the input's time
variation (error ``dt³ ü/8`` per step in the increment); for smooth motion at 100 Hz this
is far below any sensor error. An input that jumps between two samples (e.g. a pitch rate
step where a vertical curve starts) leaves an error up to ``dt · Δu/2`` in the increment
when the samples are point values of the jump; samples that are means over their
intervals (what increment and decimating sensors deliver; the simulator's,
`railnav.simulation.joint_average`) leave only a one-sample transient of at most
``dt · Δu/4``: the trapezoid over two intervals is their exact integral.

`integrate` runs the recursion in CasADi ``mapaccum`` blocks of `BLOCK_STEPS` steps (100 000
steps of the reduced model in a fraction of a second); Python loops only over blocks.
"""
from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import numpy.typing as npt

from strapdown.errors import StrapdownError

__all__ = ["rk4_step", "integrate"]


@functools.lru_cache(maxsize=32)
def rk4_step(f: ca.Function) -> ca.Function:
    """The one-step map ``step(x, u0, u1, p, dt) -> x_next`` of a model ``f``.

    Parameters
    ----------
    f : casadi.Function
        ``f(x, u) -> xdot`` or ``f(x, u, p) -> xdot`` (column vectors).

    Returns
    -------
    casadi.Function
        Inputs x (n_x), u0 and u1 (n_u, samples at both ends), p (n_p; size 1 and
        ignored for a model without parameters), dt (s); output x_next (n_x).
    """
    n_x, n_u = f.size1_in(0), f.size1_in(1)
    has_p = f.n_in() == 3
    n_p = f.size1_in(2) if has_p else 1
    x, u0, u1 = ca.SX.sym("x", n_x), ca.SX.sym("u0", n_u), ca.SX.sym("u1", n_u)
    p, dt = ca.SX.sym("p", n_p), ca.SX.sym("dt")

    def rate(xx, uu):
        return f(xx, uu, p) if has_p else f(xx, uu)

    u_mid = 0.5 * (u0 + u1)
    k1 = rate(x, u0)
    k2 = rate(x + 0.5 * dt * k1, u_mid)
    k3 = rate(x + 0.5 * dt * k2, u_mid)
    k4 = rate(x + dt * k3, u1)
    x_next = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return ca.Function(f"rk4_{f.name()}", [x, u0, u1, p, dt], [x_next],
                       ["x", "u0", "u1", "p", "dt"], ["x_next"])


#: Steps per ``mapaccum`` call: building a mapaccum costs time proportional to its length,
#: so long runs go through one cached block of this size (the last block padded).
BLOCK_STEPS = 1000


@functools.lru_cache(maxsize=32)
def _accumulated(f: ca.Function, n_steps: int) -> ca.Function:
    return rk4_step(f).mapaccum(n_steps)


def _run_blocks(f: ca.Function, x0: np.ndarray, u: np.ndarray, p_cols: np.ndarray,
                dt: float) -> np.ndarray:
    """States after each step (n_x, N) by blocks of `BLOCK_STEPS` steps."""
    n_steps = u.shape[0] - 1
    block = min(n_steps, BLOCK_STEPS)
    run = _accumulated(f, block)
    out = np.empty((x0.size, n_steps))
    x = x0
    for start in range(0, n_steps, block):
        stop = min(start + block, n_steps)
        idx = np.minimum(np.arange(start, start + block), n_steps - 1)  # pad the last block
        p_blk = p_cols if p_cols.shape[1] == 1 else p_cols[:, idx]
        states = np.asarray(run(x, u[idx].T, u[idx + 1].T, p_blk, dt), dtype=float)
        out[:, start:stop] = states[:, :stop - start]
        x = out[:, stop - 1]
    return out


def integrate(f: ca.Function, x0: npt.ArrayLike, u_samples: npt.ArrayLike, dt: float,
              p: npt.ArrayLike | None = None) -> np.ndarray:
    """Integrate ``ẋ = f(x, u[, p])`` over a sequence of IMU samples with RK4.

    Parameters
    ----------
    f : casadi.Function
        The model, ``f(x, u)`` or ``f(x, u, p)``.
    x0 : array_like, shape (n_x,)
        State at the first sample time.
    u_samples : array_like, shape (N + 1, n_u)
        Instantaneous inputs at ``t_0 ... t_N`` (see the module docstring).
    dt : float
        Sample interval, s.
    p : array_like, shape (n_p,) or (N, n_p), optional
        Model parameters, constant or one row per step (row ``k`` for ``t_k -> t_{k+1}``).

    Returns
    -------
    ndarray, shape (N + 1, n_x)
        States at ``t_0 ... t_N`` (row 0 is `x0`).

    Raises
    ------
    StrapdownError
        On inconsistent shapes or a missing/unexpected `p`.
    """
    x0 = np.asarray(x0, dtype=float).reshape(-1)
    u = np.asarray(u_samples, dtype=float)
    has_p = f.n_in() == 3
    if (p is None) == has_p:
        raise StrapdownError(f"model {f.name()} takes {f.n_in()} inputs; p must "
                             f"{'be given' if has_p else 'not be given'}")
    if x0.shape != (f.size1_in(0),) or u.ndim != 2 or u.shape[1] != f.size1_in(1):
        raise StrapdownError(f"x0 must be ({f.size1_in(0)},) and u_samples (N+1, "
                             f"{f.size1_in(1)}); got {x0.shape} and {u.shape}")
    n_steps = u.shape[0] - 1
    if n_steps < 1:
        return x0[None, :].copy()
    if p is None:
        p_cols = np.zeros((1, 1))
    else:
        p_arr = np.asarray(p, dtype=float)
        p_cols = p_arr[:, None] if p_arr.ndim == 1 else p_arr.T
        if p_cols.shape[0] != f.size1_in(2) or p_cols.shape[1] not in (1, n_steps):
            raise StrapdownError(f"p must be ({f.size1_in(2)},) or ({n_steps}, "
                                 f"{f.size1_in(2)}), got {p_arr.shape}")
    return np.vstack([x0[None, :], _run_blocks(f, x0, u, p_cols, dt).T])
