r"""Faulty measurements at the prior: the two-hypothesis row test and the common offset.

**Fault hypothesis of a row** (Herasimov et al. 2018, SEEDS.md §3, the "pulsating" filter's
fault-rejection case). Each scalar row of an update is either normal, its innovation
``ν ~ N(0, S)`` with ``S = H P Hᵀ + R`` its prior variance, or a fault: the measurement
carries no information about the state, and its innovation is drawn from a broad density,
here ``N(0, κ² S)`` with the fault scale ``κ ≫ 1``. With a prior fault probability ``p``
(independent of the past, the paper's eq. 29–30) the posterior fault probability is

    π = p f_F / (p f_F + (1 − p) f_N),
    log(π / (1 − π)) = log(p / (1 − p)) − log κ + ½ r² (1 − 1/κ²),     r² = ν² / S,

a function of the normalized innovation alone. Rejecting the row when ``π`` exceeds a
decision probability ``π_d`` is a gate ``r² > r²_thr`` (`fault_threshold`): the paper's
"3σ" gate is one such choice (``p = 0.1``, ``κ ≈ 9.5`` for ``π_d = ½``).

**Common offset** (`common_offset`): the generalized likelihood-ratio test of one unknown
offset ``a`` added to a chosen set of components (``ν = d a + e``, ``e ~ N(0, S)``,
``d`` the 0/1 indicator of the set). ``â = dᵀS⁻¹ν / dᵀS⁻¹d`` with variance ``1/dᵀS⁻¹d``;
the whole NIS splits into the offset's ``â²/var(â)`` (χ²₁ without an offset) and the
residual's (χ²_{m−1}). A large offset part with a consistent residual says that every
component of the set moved together (a jump of a state the set shares), not that one
of them failed.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import numpy.typing as npt

from ekf.errors import ModelError

__all__ = ["fault_log_odds", "fault_probability", "fault_threshold", "common_offset"]

Array = npt.NDArray[np.float64]


def _check(prior: float, scale: float) -> None:
    if not 0.0 < prior < 1.0:
        raise ModelError(f"fault prior must be in (0, 1), got {prior!r}")
    if not scale > 1.0:
        raise ModelError(f"fault scale must be > 1, got {scale!r}")


def fault_log_odds(nis: npt.ArrayLike, *, prior: float, scale: float) -> Array:
    """``log(π/(1 − π))`` of each row's fault hypothesis (module docstring).

    Parameters
    ----------
    nis : array_like, shape (m,)
        Normalized innovation squared ``ν²/S`` of each scalar row (dimensionless).
    prior : float
        Prior fault probability ``p`` of a row, in (0, 1).
    scale : float
        Fault scale ``κ`` > 1: a fault's innovation has ``κ`` times the normal spread.

    Returns
    -------
    ndarray, shape (m,)
    """
    r2 = np.asarray(nis, dtype=float)
    return _prior_log_odds(prior, scale) + 0.5 * r2 * (1.0 - 1.0 / (scale * scale))


@lru_cache(maxsize=64)
def _prior_log_odds(prior: float, scale: float) -> float:
    """``log(p/(1 − p)) − log κ`` (`fault_log_odds`'s constant: once per configuration,
    the same number), after the parameters' check."""
    _check(prior, scale)
    return np.log(prior / (1.0 - prior)) - np.log(scale)


def fault_probability(nis: npt.ArrayLike, *, prior: float, scale: float) -> Array:
    """Posterior fault probability ``π`` of each row (parameters of `fault_log_odds`).

    Returns
    -------
    ndarray, shape (m,)
        In [0, 1].
    """
    log_odds = fault_log_odds(nis, prior=prior, scale=scale)
    return 0.5 * (1.0 + np.tanh(0.5 * log_odds))   # logistic, no overflow


def fault_threshold(*, prior: float, scale: float, decision: float = 0.5) -> float:
    """The NIS ``r²`` above which ``π > decision``.

    Parameters
    ----------
    prior, scale : float
        As in `fault_log_odds`.
    decision : float
        Decision probability ``π_d`` in (0, 1).

    Returns
    -------
    float
        ``2 (log((1 − p)/p) + log κ + log(π_d/(1 − π_d))) / (1 − 1/κ²)`` (0 when negative:
        every row is then a fault).
    """
    _check(prior, scale)
    if not 0.0 < decision < 1.0:
        raise ModelError(f"decision probability must be in (0, 1), got {decision!r}")
    value = 2.0 * (np.log((1.0 - prior) / prior) + np.log(scale)
                   + np.log(decision / (1.0 - decision))) / (1.0 - 1.0 / (scale * scale))
    return float(max(value, 0.0))


def common_offset(innov: npt.ArrayLike, S: npt.ArrayLike, members: npt.ArrayLike
                  ) -> tuple[float, float, float, float]:
    """GLR test of one offset shared by the components `members` (module docstring).

    Parameters
    ----------
    innov : array_like, shape (m,)
        Innovation ``ν`` (units of the measurements).
    S : array_like, shape (m, m)
        Its covariance (SPD).
    members : array_like of bool, shape (m,)
        Components that share the offset (at least one).

    Returns
    -------
    offset : float
        ``â``, units of the member components.
    variance : float
        ``var(â) = 1 / dᵀS⁻¹d``.
    nis_offset : float
        ``â² / var(â)``: χ²₁ when there is no offset.
    nis_residual : float
        ``νᵀS⁻¹ν − nis_offset``: χ²_{m−1} when the offset model holds.

    Raises
    ------
    ModelError
        No member, or shapes that disagree.
    """
    nu = np.asarray(innov, dtype=float)
    S = np.asarray(S, dtype=float)
    d = np.asarray(members, dtype=bool).astype(float)
    if S.shape != (nu.size, nu.size) or d.shape != nu.shape:
        raise ModelError(f"common_offset: innov {nu.shape}, S {S.shape}, members {d.shape}")
    if not np.count_nonzero(d):                # (d.any(), without its wrapper)
        raise ModelError("common_offset needs at least one member component")
    both = np.empty((nu.size, 2))             # np.column_stack([nu, d]), without its wrapper
    both[:, 0], both[:, 1] = nu, d
    w_nu, w_d = np.linalg.solve(S, both).T
    info = float(d @ w_d)
    offset = float(d @ w_nu) / info
    nis_offset = offset * offset * info
    return offset, 1.0 / info, nis_offset, float(nu @ w_nu) - nis_offset
