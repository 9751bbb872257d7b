"""Tail probabilities of the divergence monitor's tests (`railnav.navigation.monitor`,
`railnav.navigation.network_status`): χ² and binomial, through `scipy.special`'s ufuncs,
imported at the first call, with scalar paths that avoid NumPy's array calls (an epoch's
test calls them 5-6 times).
"""
from __future__ import annotations

import math
from functools import cache

import numpy as np

__all__ = ["binom_sf", "chi2_cdf", "chi2_isf", "chi2_sf", "fix_disagreement_tail",
           "row_false_rejection_p", "sigma_gate"]


@cache
def _special():
    """`scipy.special`, imported at the first test, not with this module (its imports stay
    free of SciPy, as the start-up wants: ``tests/railnav/commands/test_cli_startup.py``); a
    ``from scipy.special import`` in each function cost ~2 µs a call, 5-6 calls an epoch."""
    import scipy.special
    return scipy.special


@cache
def _scalar():
    """`scipy.special.cython_special`: the same C functions as `scipy.special`'s ufuncs
    (the same numbers), called on Python floats without a ufunc's array handling (~0.1
    against ~1 µs a call; an epoch's test makes some nine); imported at the first test,
    as `_special`."""
    import scipy.special.cython_special
    return scipy.special.cython_special


def chi2_cdf(value: float, dof: float) -> float:
    """Lower χ² tail ``P(χ²_dof ≤ value)``, 1 where ``dof <= 0``."""
    return _scalar().chdtr(float(dof), float(value)) if dof > 0 else 1.0


def chi2_isf(p: float, dof: int) -> float:
    """The χ² quantile with upper tail `p`."""
    return float(_special().chdtri(dof, p))


@cache
def sigma_gate(p: float) -> float:
    """The χ²₁ quantile of `p` as a number of σ (4.89 at 1e-6)."""
    return math.sqrt(chi2_isf(p, 1))


def binom_sf(k, n, p):
    """``P(X ≥ k)``, ``X ~ Binomial(n, p)``, 1 where ``k <= 0``: a float for scalar `k`
    (an epoch's test, without NumPy's array calls), else elementwise, an array (the
    network run's records, `railnav.navigation.network_status`)."""
    if isinstance(k, int) or np.ndim(k) == 0:
        return 1.0 if k <= 0 else _scalar().bdtrc(int(k - 1), int(n), float(p))
    k, n = np.asarray(k, dtype=np.int64), np.asarray(n, dtype=np.int64)
    return np.where(k > 0, _special().bdtrc(np.maximum(k - 1, 0), n, p), 1.0)


def chi2_sf(values, dofs):
    """Upper χ² tails ``P(χ²_dof > value)``, 1 where ``dof <= 0``: a float for a scalar
    `values` (an epoch's test, without NumPy's array calls), else elementwise, an array
    (one call of SciPy's ufunc for all; each element the bits of a call of its own)."""
    if isinstance(values, float) or np.ndim(values) == 0:
        return _scalar().chdtrc(float(dofs), float(values)) if dofs > 0 else 1.0
    return np.where(dofs > 0, _special().chdtrc(dofs, values), 1.0)


def row_false_rejection_p(gate_probability: float | None, nis_threshold: float | None
                          ) -> float | None:
    """Probability that a fault-free row is rejected: by the fault screen's row test
    (``P(χ²₁ > nis_threshold)``) or the χ² row gate (``1 − gate_probability``), a union
    bound; None where neither rejects rows (the rejected-row tests are then off)."""
    p = 0.0 if gate_probability is None else 1.0 - float(gate_probability)
    if nis_threshold is not None:
        p += float(_special().chdtrc(1.0, float(nis_threshold)))
    return p if p > 0.0 else None


def fix_disagreement_tail(d2_sum: float, d_sum: float, n: int) -> float:
    """The monitor's fix-disagreement tail of `n` fixes: ``Σ d²`` against χ²ₙ and the signed
    mean ``(Σ d)²/n`` against χ²₁, the smaller tail doubled (Bonferroni)."""
    return min(1.0, 2.0 * min(chi2_sf(d2_sum, n), chi2_sf(d_sum ** 2 / max(n, 1), min(n, 1))))
