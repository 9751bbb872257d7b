"""Row arithmetic of the fault screen (`railnav.filters.fault_detection.RowScreen`):
innovations, Jacobians and variances of an epoch's rows at the prior, the rows of a subset,
and the statuses of row groups (a GNSS fix's rows are used together or not at all).

`innovation_covariances` and `influence_gains` take the rows of several filters (a bank's
hypotheses, `railnav.filters.fault_detection.screen_together`) and compute those of equal
shapes in one stacked call (NumPy's stacked ``matmul`` and ``solve`` make each matrix's
BLAS/LAPACK call as for that matrix alone: each filter's numbers are its own, to the bit).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import numpy.typing as npt

from ekf.update import Observation

__all__ = ["evaluate_rows", "subset_rows", "group_status", "innovation_covariances",
           "innovation_covariance",
           "influence_gains", "own_covariance", "row_ids", "ROW_STATUSES"]

Array = npt.NDArray[np.float64]

#: Row statuses of ``innovations.csv``: given to the update, rejected at this epoch, or
#: not used because the row's channel is excluded (`railnav.filters.fault_detection`).
ROW_STATUSES = ("used", "rejected", "excluded")


@lru_cache(maxsize=64)
def row_ids(m: int) -> npt.NDArray[np.intp]:
    """``np.arange(m)``, read only (the used rows' ids of an update, shared by the epochs
    of `m` rows)."""
    ids = np.arange(m)
    ids.flags.writeable = False
    return ids


def group_status(status: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Rows of a group with a row not used are rejected (`RowScreen.screen`)."""
    out = status.copy()
    grouped = groups >= 0
    if not np.count_nonzero(grouped):          # no group (GNSS rows only): nothing to tie
        return out
    not_used = grouped & (status != ROW_STATUSES[0])
    if not np.count_nonzero(not_used):         # every grouped row used: nothing to reject
        return out
    bad = np.unique(groups[not_used])
    out[np.isin(groups, bad) & (status == ROW_STATUSES[0])] = ROW_STATUSES[1]
    return out


def evaluate_rows(observations: list[Observation], x: Array) -> tuple[Array, Array, Array]:
    """Innovations ``z − h(x)``, Jacobians and noise variances of all rows."""
    n = x.size
    if not observations:
        return np.zeros(0), np.zeros((0, n)), np.zeros(0)
    nus, Hs, Rs = [], [], []
    for obs in observations:
        if obs.R.ndim != 1 or obs.model.k != 1:
            raise ValueError(f"{obs.model.name}: the row screen needs scalar rows with "
                             "diagonal R (variances)")
        z_pred, H = obs.model.evaluate(x, obs.p)
        nus.append(obs.z.reshape(-1) - z_pred)
        Hs.append(H)
        Rs.append(obs.R)
    # the (m_i, n) Jacobians stacked (np.vstack's concatenation, without its wrapper)
    return np.concatenate(nus), np.concatenate(Hs), np.concatenate(Rs)


def subset_rows(observations: list[Observation], keep: npt.NDArray[np.bool_]
                ) -> list[Observation]:
    """The observations restricted to the rows `keep` (in the stacked order)."""
    out, start = [], 0
    for obs in observations:
        k = keep[start:start + obs.rows]
        start += obs.rows
        n_kept = np.count_nonzero(k)             # (k.all(), k.any() without wrappers)
        if n_kept == k.size:
            out.append(obs)
        elif n_kept:
            out.append(obs.subset(k))
    return out


def innovation_covariances(rows: list[tuple[Array, Array, Array]]
                           ) -> list[tuple[Array, Array]]:
    """``S = H P Hᵀ + diag(R)`` of each filter's rows, with ``H P`` (the influence gains'
    right-hand side, `influence_gains`) (module docstring).

    Parameters
    ----------
    rows : list of (H (m, n), P (n, n), R (m,))

    Returns
    -------
    list of (ndarray (m, m), ndarray (m, n))
        ``S`` and ``H P`` of each.
    """
    return _by_shape(innovation_covariance, rows)


def innovation_covariance(H: Array, P: Array, R: Array) -> tuple[Array, Array]:
    """``S = H P Hᵀ + diag(R)`` and ``H P`` of one filter's rows, or of several stacked
    on a leading axis: ``(H P) Hᵀ``, then ``+ 0`` off the diagonal and ``+ R`` on it in
    place (the numbers of ``H @ P @ Hᵀ + np.diag(R)``, without the diagonal matrix)."""
    HP = H @ P
    S = HP @ np.swapaxes(H, -1, -2)
    m = R.shape[-1]
    S += 0.0                                     # (-0 off the diagonal: +0, as `+ diag(R)`)
    S.reshape(R.shape[:-1] + (m * m,))[..., ::m + 1] += R      # every (m+1)-th element
    return S, HP


def own_covariance(S: Array, R: Array, inflation: Array) -> Array:
    """``S`` with each row's variance ``R`` replaced by its own, ``R / inflation``:
    ``S₀ = H P Hᵀ + diag(R / inflation)`` from ``S = H P Hᵀ + diag(R)`` (the fault
    screen's tests of rows whose update variance is inflated for correlated errors,
    `railnav.filters.fault_detection`)."""
    m = R.size
    S0 = S.copy()
    S0.reshape(m * m)[::m + 1] += R / inflation - R          # the diagonal, in place
    return S0


def influence_gains(rows: list[tuple[Array, Array]]) -> list[Array]:
    """``Kᵀ = S⁻¹ H P`` of each filter's used rows (``S`` symmetric; module docstring).

    Parameters
    ----------
    rows : list of (S (m, m), H P (m, n))

    Returns
    -------
    list of ndarray, shape (m, n)
    """
    return _by_shape(np.linalg.solve, rows)


def _by_shape(fun, rows: list[tuple]) -> list:
    """``fun(*row)`` of each row, the rows whose arrays have equal shapes stacked into one
    call (`fun` broadcasts over a leading axis)."""
    if len(rows) == 1:                              # one filter: nothing to stack
        return [fun(*rows[0])]
    out: list = [None] * len(rows)
    groups: dict[tuple, list[int]] = {}
    for k, row in enumerate(rows):
        groups.setdefault(tuple(a.shape for a in row), []).append(k)
    for members in groups.values():
        if len(members) == 1:
            out[members[0]] = fun(*rows[members[0]])
            continue
        found = fun(*(np.stack(parts) for parts in zip(*(rows[k] for k in members))))
        if isinstance(found, tuple):                # several outputs, each stacked
            found = zip(*found)
        for k, one in zip(members, found):
            out[k] = one
    return out
