"""Receiver clock jumps among a filter's GNSS rows, tested at the prior by the fault screen.

A step of the receiver clock moves every pseudorange by the same amount and no range rate.
The common-offset GLR test (`ekf.outliers.common_offset` on the pseudorange rows of the
admitted channels, with the full innovation covariance ``S = H P Hᵀ + R``) declares a jump
when the offset part of the NIS exceeds the χ²₁ quantile of
`railnav.filters.fault_config.FaultDetectionConfig.clock_jump_false_alarm` while the
residual is consistent (χ²_{m−1} at `CLOCK_RESIDUAL_PROBABILITY`). The clock bias then gets
the jump variance ``(clock_jump_sigma_factor · â)²`` added to its prior variance
(`ekf.EpochRows`, by `railnav.filters.fault_detection.RowScreen`): the update estimates the
jump from all rows and no satellite is blamed. Without it every pseudorange would fail and
every satellite be excluded.

**Most epochs need no test.** With ``S = H P Hᵀ + diag(n)`` (``P`` positive semidefinite,
variances ``n > 0``), ``S ⪰ diag(n)``, so ``νᵀS⁻¹ν <= Σ νᵢ²/nᵢ``, and the offset part of
the GLR is at most the whole NIS (its residual part is a squared projection, ``>= 0``);
over the admitted rows it is at most that sum over all rows. Given the rows' variances
`find_clock_jump` takes ``Σ νᵢ²/nᵢ`` below `NIS_BOUND_MARGIN` times the χ²₁ threshold as
no jump without solving with ``S`` (96 % of the paper2017 trip's epochs): the same
decision, the margin far above rounding.
"""
from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt

from ekf.gating import chi2_threshold
from ekf.outliers import common_offset
from railnav.filters.fault_config import FaultDetectionConfig

__all__ = ["find_clock_jump", "CLOCK_RESIDUAL_PROBABILITY", "JUMP_ROW_KIND", "MIN_JUMP_ROWS",
           "NIS_BOUND_MARGIN"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: The residual of a declared clock jump must be consistent at this probability (the row
#: gate's level: a jump is not declared while one satellite also fails).
CLOCK_RESIDUAL_PROBABILITY = 0.9999
#: Rows that move with the receiver clock bias.
JUMP_ROW_KIND = "pseudorange"
#: A common offset is tested only on at least this many pseudoranges (with fewer, one
#: faulty satellite and a clock jump cannot be told apart).
MIN_JUMP_ROWS = 4
#: ``Σ νᵢ²/nᵢ`` below this fraction of the offset's χ²₁ threshold declares no jump without
#: the test (module docstring; rounding moves the bound and the test by ~1e-13 relative).
NIS_BOUND_MARGIN = 0.9


def find_clock_jump(config: FaultDetectionConfig, kind: np.ndarray, nu: Array, S: Array,
                    admitted: npt.NDArray[np.bool_] | None = None,
                    noise: Array | None = None) -> tuple[float, float] | None:
    """The receiver clock jump an epoch's rows declare (module docstring).

    Parameters
    ----------
    config : FaultDetectionConfig
        With ``clock_jump_false_alarm`` set (not None).
    kind : ndarray of str, shape (m,)
        Kind of each row (`railnav.filters.common.ROW_KINDS`); the `JUMP_ROW_KIND` rows
        are tested.
    nu : ndarray, shape (m,)
        Innovations at the prior, m or m/s.
    S : ndarray, shape (m, m)
        Their covariance.
    admitted : ndarray of bool, shape (m,), optional
        The rows whose channels are admitted (not excluded); None: every row.
    noise : ndarray, shape (m,), optional
        The rows' variances in `S` (``S − diag(noise)`` positive semidefinite), m² or
        m²/s²: an epoch whose ``Σ ν²/noise`` is small is passed without the test (module
        docstring); None: always tested.

    Returns
    -------
    (float, float) or None
        The common pseudorange offset (m) and the jump variance added to the clock bias's
        (m²); None: no jump declared.
    """
    threshold = chi2_threshold(1.0 - config.clock_jump_false_alarm, 1)
    if noise is not None and float(nu @ (nu / noise)) < NIS_BOUND_MARGIN * threshold:
        return None                      # (first: most epochs end here)
    every = admitted is None
    members = np.asarray(kind) == JUMP_ROW_KIND
    n_rows = members.size
    if not every:
        members = members[admitted]
    if np.count_nonzero(members) < MIN_JUMP_ROWS:
        return None
    offset, _, nis_offset, nis_residual = common_offset(
        nu, S, members) if every else common_offset(
        nu[admitted], S[np.ix_(admitted, admitted)], members)
    if nis_offset <= threshold:
        return None
    n_admitted = n_rows if every else int(admitted.sum())
    if nis_residual > chi2_threshold(CLOCK_RESIDUAL_PROBABILITY, n_admitted - 1):
        log.debug("common pseudorange offset %.1f m with an inconsistent residual: "
                  "not taken for a clock jump", offset)
        return None
    log.debug("receiver clock jump of %.1f m", offset)
    return offset, (config.clock_jump_sigma_factor * offset) ** 2
