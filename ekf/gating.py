"""Innovation gates: which measurements of an update are believed.

A gate compares a normalized innovation with a threshold.

``kind="chi2"``
    ``νᵀ S⁻¹ ν ≤ χ²_dof⁻¹(probability)`` (`chi2_quantile`): a consistent, fault-free
    measurement passes with the given probability.
``kind="trace"``
    ``νᵀ ν ≤ trace_factor · tr(S)`` — the anomaly test of Ivanov et al. 2021 (SEEDS.md
    §2, eqs. 27–32; ``trace_factor`` 9 ≈ 0.997, 4 ≈ 0.954).

``scope`` says what is tested: ``"vector"`` the whole update at once (all rejected if it
fails), ``"rows"`` each measurement row (e.g. one satellite's pseudorange) against its own
marginal block of ``S`` — failing rows are dropped and the rest used. With sequential
processing (:func:`ekf.update.kalman_update`, ``sequential=True``) each scalar is tested
against its sequential innovation variance.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
from scipy.special import gammaincinv

from ekf.errors import ModelError

__all__ = ["Gate", "chi2_threshold", "chi2_quantile"]

Array = npt.NDArray[np.float64]


def chi2_quantile(probability: float, dof: float) -> float:
    """``χ²_dof⁻¹(probability)``: ``2 P⁻¹(dof/2, probability)`` with ``P`` the regularized
    lower incomplete gamma function — the formula of ``scipy.stats.chi2.ppf`` (equal to
    the bit), without importing ``scipy.stats`` (~0.4 s at every start)."""
    return float(2.0 * gammaincinv(dof / 2, probability))


@lru_cache(maxsize=1024)
def chi2_threshold(probability: float, dof: int) -> float:
    """``χ²`` quantile: the NIS below which a consistent ``dof``-dimensional innovation
    falls with ``probability``."""
    return chi2_quantile(probability, dof)


@dataclass(frozen=True)
class Gate:
    """An innovation gate.

    Attributes
    ----------
    probability : float
        Acceptance probability of a consistent innovation, in (0, 1) (``kind="chi2"``).
    kind : {"chi2", "trace"}
    scope : {"vector", "rows"}
    trace_factor : float
        ``γ̃`` of the trace test (``kind="trace"``), > 0.
    """

    probability: float = 0.9973
    kind: Literal["chi2", "trace"] = "chi2"
    scope: Literal["vector", "rows"] = "vector"
    trace_factor: float = 9.0

    def __post_init__(self) -> None:
        if not 0.0 < self.probability < 1.0:
            raise ModelError(f"gate probability must be in (0, 1), got {self.probability}")
        if self.kind not in ("chi2", "trace"):
            raise ModelError(f"gate kind must be 'chi2' or 'trace', not {self.kind!r}")
        if self.scope not in ("vector", "rows"):
            raise ModelError(f"gate scope must be 'vector' or 'rows', not {self.scope!r}")
        if not self.trace_factor > 0.0:
            raise ModelError(f"gate trace_factor must be > 0, got {self.trace_factor}")

    def passes(self, innov: Array, S: Array) -> tuple[bool, float, float]:
        """Test one innovation.

        Parameters
        ----------
        innov : ndarray, shape (m,)
        S : ndarray, shape (m, m)
            Its covariance (SPD).

        Returns
        -------
        passed : bool
        statistic : float
            NIS (``chi2``) or ``νᵀν`` (``trace``).
        threshold : float
        """
        m = innov.size
        if self.kind == "trace":
            statistic, threshold = float(innov @ innov), self.trace_factor * float(np.trace(S))
        else:
            statistic = float(innov @ sla.cho_solve(sla.cho_factor(S, lower=True), innov))
            threshold = chi2_threshold(self.probability, m)
        return statistic <= threshold, statistic, threshold

    def accepted_rows(self, innov: Array, S: Array, groups: Array) -> Array:
        """Mask of the components that pass.

        Parameters
        ----------
        innov : ndarray, shape (m,)
        S : ndarray, shape (m, m)
        groups : ndarray of int, shape (m,)
            Row id of each component (components of one row share an id).

        Returns
        -------
        ndarray of bool, shape (m,)
        """
        if self.scope == "vector":
            return np.full(innov.size, self.passes(innov, S)[0])
        increasing = groups.size < 2 or bool(np.all(groups[1:] > groups[:-1]))
        if increasing and groups.size == innov.size or np.unique(groups).size == innov.size:
            # scalar rows (distinct ids: increasing ones need no np.unique)
            return self.scalar_rows_accepted(innov, S)
        accepted = np.zeros(innov.size, dtype=bool)
        for g in np.unique(groups):
            rows = np.flatnonzero(groups == g)
            accepted[rows] = self.passes(innov[rows], S[np.ix_(rows, rows)])[0]
        return accepted

    def scalar_rows_accepted(self, innov: Array, S: Array) -> Array:
        """`accepted_rows` of rows that are each their own row (distinct ids): each
        component's test on its own variance, vectorized; of several members at once
        with a leading axis (a bank's, `ekf.stacked.update_members`: elementwise, each
        member's mask as alone).

        Parameters
        ----------
        innov : ndarray, shape (..., m)
        S : ndarray, shape (..., m, m)

        Returns
        -------
        ndarray of bool, shape (..., m)
        """
        if self.scope == "vector":
            raise ModelError("scalar_rows_accepted is the row test (scope 'rows')")
        var = np.diagonal(S, axis1=-2, axis2=-1)
        if self.kind == "trace":
            return innov * innov <= self.trace_factor * var
        return innov * innov <= chi2_threshold(self.probability, 1) * var
