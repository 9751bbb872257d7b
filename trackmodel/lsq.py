"""Levenberg–Marquardt for the fitter's small, bounded least-squares problems.

The fits have few parameters (tens to hundreds) and up to thousands of residuals. The
step comes from the normal equations ``(JᵀJ + λ D) δ = −Jᵀr`` with Marquardt's diagonal
scaling ``D = diag(JᵀJ)``; bounds are kept by projecting each step. (A tall
least-squares solve by SVD or QR, as in `scipy.optimize.least_squares`, runs into
multi-threaded LAPACK, which on a busy machine was measured hundreds of times slower than
the normal equations' small products.)
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
from scipy import sparse
from scipy.sparse.linalg import spsolve

__all__ = ["levenberg_marquardt"]

Array = npt.NDArray[np.float64]

#: Initial damping (relative to diag(JᵀJ)) and its ceiling; it is updated by Nielsen's rule
#: (H. B. Nielsen, "Damping parameter in Marquardt's method", IMM-REP-1999-05, DTU).
LM_DAMPING = 1e-3
LM_MAX_DAMPING = 1e8
#: The iteration stops after `LM_SMALL_STEPS` steps in a row lowered the cost by less than
#: this fraction each (1 % of the cost is 0.5 % of the RMS residual): the fits have flat,
#: curved valleys (e.g. where a joint of two nearly collinear transitions may slide) along
#: which further steps creep for little gain.
LM_RTOL = 1e-2
LM_SMALL_STEPS = 2


def _solve(A, b: Array) -> Array:
    """``A⁻¹ b`` for a dense or a sparse (CSC) matrix."""
    if sparse.issparse(A):
        x = spsolve(A, b)
        if not np.all(np.isfinite(x)):
            raise np.linalg.LinAlgError("singular matrix")
        return x
    return np.linalg.solve(A, b)


def _bounded_step(A, g: Array, x: Array, lower: Array, upper: Array) -> Array:
    """Solve ``A δ = −g`` with the parameters that sit on a bound and would leave the box
    held fixed (one pass of an active set: a projected step need not descend)."""
    step = -_solve(A, g)
    held = ((x <= lower) & (step < 0.0)) | ((x >= upper) & (step > 0.0))
    if held.any():
        free = np.flatnonzero(~held)
        step = np.zeros_like(x)
        sub = A[free][:, free] if sparse.issparse(A) else A[np.ix_(free, free)]
        step[free] = -_solve(sub, g[free])
    return step


def levenberg_marquardt(residuals: Callable[[Array], Array], jacobian: Callable[[Array], Array],
                        x0: Array, lower: Array, upper: Array, *, max_iterations: int,
                        rtol: float = LM_RTOL) -> Array:
    """Minimise ``|r(x)|²`` within ``lower <= x <= upper``.

    Parameters
    ----------
    residuals : callable
        ``r(x)``, shape (M,).
    jacobian : callable
        ``∂r/∂x`` at x, shape (M, P), a NumPy array or a SciPy sparse matrix (called after
        ``residuals`` at the same x).
    x0, lower, upper : ndarray, shape (P,)
        Start and bounds (±inf for none).
    max_iterations : int
        Accepted steps at most.
    rtol : float
        Stop when `LM_SMALL_STEPS` steps in a row lowered the cost by less than this
        fraction each.

    Returns
    -------
    ndarray, shape (P,)
    """
    x = np.clip(x0, lower, upper)
    r = residuals(x)
    cost = r @ r
    lam, nu, small = None, 2.0, 0
    for _ in range(max_iterations):
        J = jacobian(x)
        H, g = J.T @ J, J.T @ r
        diag = H.diagonal()
        d = np.maximum(diag, 1e-12 * max(diag.max(), 1e-300))
        D = sparse.diags(d, format="csc") if sparse.issparse(H) else np.diag(d)
        if sparse.issparse(H):
            H = H.tocsc()
        lam = LM_DAMPING if lam is None else lam
        while lam <= LM_MAX_DAMPING:
            try:
                step = _bounded_step(H + lam * D, g, x, lower, upper)
            except np.linalg.LinAlgError:
                lam, nu = lam * nu, 2.0 * nu
                continue
            trial = np.clip(x + step, lower, upper)
            r_trial = residuals(trial)
            c_trial = r_trial @ r_trial
            predicted = cost - np.sum((r + J @ (trial - x)) ** 2)
            if c_trial < cost and predicted > 0.0:
                rho = (cost - c_trial) / predicted
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)     # Nielsen (1999)
                nu = 2.0
                break
            lam, nu = lam * nu, 2.0 * nu
        else:
            return x
        small = small + 1 if cost - c_trial <= rtol * cost else 0
        x, r, cost = trial, r_trial, c_trial
        if small >= LM_SMALL_STEPS:
            break
    return x
