"""Filter consistency statistics: NEES, NIS and their χ² acceptance bands.

For a consistent filter the normalized estimation error squared
``NEES = eᵀ P⁻¹ e`` of an ``n``-state is ``χ²_n``, and the normalized innovation squared
``NIS = νᵀ S⁻¹ ν`` of an ``m``-measurement is ``χ²_m``. Averaged over ``R`` independent
Monte Carlo runs, ``R · mean ~ χ²_{R n}``: :func:`chi2_band` gives the two-sided band of
that average (Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and
Navigation*, 2001, §5.4).
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ekf.gating import chi2_quantile

__all__ = ["normalized_squares", "chi2_band"]

Array = npt.NDArray[np.float64]


def normalized_squares(err: npt.ArrayLike, cov: npt.ArrayLike) -> Array:
    """``eᵀ C⁻¹ e`` (NEES for state errors, NIS for innovations), by Cholesky.

    Parameters
    ----------
    err : array_like, shape (..., n)
    cov : array_like, shape (..., n, n)
        Symmetric positive definite.

    Returns
    -------
    ndarray, shape (...)
    """
    err = np.asarray(err, dtype=float)
    L = np.linalg.cholesky(np.asarray(cov, dtype=float))
    white = np.linalg.solve(L, err[..., None])[..., 0]
    return np.sum(white ** 2, axis=-1)


def chi2_band(dof: int, runs: int, probability: float = 0.95) -> tuple[float, float]:
    """Two-sided band of the average of ``runs`` independent ``χ²_dof`` values.

    Returns
    -------
    low, high : float
        ``P(low <= mean <= high) = probability``.
    """
    tail = 0.5 * (1.0 - probability)
    total = dof * runs
    return chi2_quantile(tail, total) / runs, chi2_quantile(1.0 - tail, total) / runs
