r"""Huber-like down-weighting of GNSS rows at the prior: robust to urban multipath.

Urban code multipath gives pseudoranges that are off by several σ for seconds at a time.
A χ² gate (`ekf.Gate`) rejects the gross ones, but the moderate ones (3–4σ) pass and pull
the estimate with full weight. `huber_inflate` applies, before the update, the weight of
Huber's M-estimator (Huber 1964; for Kalman filters e.g. Karlgaard & Schaub 2007, "Huber-
based divided difference filtering", *J. Guid. Control Dyn.* 30(3)) to each scalar row:
with the prior's normalized innovation ``r = |ν| / √S`` (``S = H P Hᵀ + R``),

    w = 1            for r ≤ k,
    w = k / r        for r > k,

and the row's variance is inflated so that its innovation variance becomes ``S / w``
(``R' = R + (1/w − 1) S``). A row at ``r`` then enters the update as one at
``√(k r)`` normalized innovation with ``w`` times the information of the original: the
influence of a row grows like ``√r`` instead of ``r``. A gross outlier still fails the
gate that follows (``√(k r)`` above the gate threshold for ``r`` beyond
``threshold² / k``). With ``k → ∞`` nothing changes.

Rows are treated one scalar at a time (their innovation covariances are taken
marginally, as the row gate does).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from ekf.update import Observation

__all__ = ["huber_inflate", "huber_variance_scale", "DEFAULT_HUBER_K"]

Array = npt.NDArray[np.float64]

#: Huber threshold in σ of the innovation: 1.5 is the usual choice (95 % efficiency at the
#: Gaussian), also `gnss_obs.spp.SppConfig.huber_k`'s default.
DEFAULT_HUBER_K = 1.5


def huber_variance_scale(normalized: npt.ArrayLike, k: float) -> Array:
    """``1/w``: the factor on a row's innovation variance (module docstring).

    Parameters
    ----------
    normalized : array_like, shape (m,)
        ``|ν| / √S`` of each row (dimensionless).
    k : float
        Huber threshold, > 0.

    Returns
    -------
    ndarray, shape (m,)
        ``max(1, r / k)``.
    """
    r = np.abs(np.asarray(normalized, dtype=float))
    return np.maximum(1.0, r / k)


def huber_inflate(observations: Sequence[Observation], x: Array, P: Array, *,
                  k: float = DEFAULT_HUBER_K) -> tuple[list[Observation], int]:
    """The observations with the noise of outlying rows inflated at the prior ``(x, P)``.

    Parameters
    ----------
    observations : sequence of ekf.Observation
        With diagonal ``R`` (variances, shape ``(m * k_rows,)``).
    x : ndarray, shape (n,)
        Prior state.
    P : ndarray, shape (n, n)
        Prior covariance.
    k : float
        Huber threshold, in σ of the innovation.

    Returns
    -------
    observations : list of ekf.Observation
        Same rows, ``R`` inflated where ``|ν| > k √S``.
    n_inflated : int
        Number of scalar rows inflated.
    """
    out, n_inflated = [], 0
    for obs in observations:
        if obs.R.ndim != 1:
            raise ValueError(f"{obs.model.name}: huber_inflate needs diagonal R (variances)")
        z_pred, H = obs.model.evaluate(x, obs.p)
        innov = obs.z.reshape(-1) - z_pred
        S = np.einsum("ij,jk,ik->i", H, P, H) + obs.R
        scale = huber_variance_scale(innov / np.sqrt(S), k)
        inflated = scale > 1.0
        n_inflated += int(inflated.sum())
        out.append(replace(obs, R=obs.R + (scale - 1.0) * S) if inflated.any() else obs)
    return out, n_inflated
