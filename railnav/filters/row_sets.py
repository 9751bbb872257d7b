"""Row arithmetic of the fault screen (`railnav.filters.fault_detection.RowScreen`):
innovations, Jacobians and variances of an epoch's rows at the prior, the rows of a subset,
and the statuses of row groups (a GNSS fix's rows are used together or not at all)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from ekf.update import Observation

__all__ = ["evaluate_rows", "subset_rows", "group_status", "ROW_STATUSES"]

Array = npt.NDArray[np.float64]

#: Row statuses of ``innovations.csv``: given to the update, rejected at this epoch, or
#: not used because the row's channel is excluded (`railnav.filters.fault_detection`).
ROW_STATUSES = ("used", "rejected", "excluded")


def group_status(status: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Rows of a group with a row not used are rejected (`RowScreen.screen`)."""
    out = status.copy()
    if not np.count_nonzero(groups >= 0):      # no group (GNSS rows only): nothing to tie
        return out
    bad = np.unique(groups[(groups >= 0) & (status != ROW_STATUSES[0])])
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
            out.append(replace(obs, z=obs.z[k], R=obs.R[k], p=obs.p[k]))
    return out
