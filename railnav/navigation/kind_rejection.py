r"""The divergence monitor's whole-kind test (`railnav.navigation.monitor`,
``p_kind_rejected``): every satellite's row of one kind failing the fault screen's row test
at once.

Independent satellites do not all fail together; a filter whose prior is wrong makes them
(a speed many σ off fails every range rate, a position off every pseudorange). One receiver
fault can too: a step of the receiver clock moves every row of a kind by one common offset
(a clock jump every pseudorange, which the screen itself takes as a jump,
`railnav.filters.fault_detection`; a clock-drift step every range rate, which it does not).
So the statistic is the rows' NIS *after* one common offset is removed, with their full
innovation covariance ``S = H P Hᵀ + R`` at the prior (`ekf.outliers.common_offset`),
χ²_{m−1} for a consistent filter whatever the rows' correlations through the prior. The
test is taken only for a kind of at least `MIN_KIND_ROWS` rows *all* of which are beyond the
screen's row gate (`FaultDetectionConfig.nis_threshold`), whatever their status (rows of a
channel the screen has excluded too: a filter that stays wrong excludes them after three
epochs); otherwise its tail is 1. That condition only lowers the false-alarm rate: for a
consistent filter ``P(p_kind_rejected < p) ≤ p`` for each kind, ≤ 2p over the two
(`KINDS`). Multipath on a few satellites leaves the others passing: no test.
"""
from __future__ import annotations

import numpy as np

from ekf.outliers import common_offset
from railnav.filters.common import ROW_KINDS
from railnav.filters.fault_detection import key_kind
from railnav.navigation.tail_probabilities import chi2_sf

__all__ = ["KINDS", "MIN_KIND_ROWS", "kind_rejected_tail"]

#: The kinds tested: one row per satellite (a fix's rows are one solution, not independent).
KINDS = ROW_KINDS
#: Fewest rows of a kind to test (the screen's clock-jump test asks as many: with fewer, one
#: or two faulty satellites and a common cause cannot be told apart).
MIN_KIND_ROWS = 4


def kind_rejected_tail(epoch, nis_threshold: float) -> float:
    """The smallest χ²_{m−1} tail of the residual NIS over the kinds of `epoch` whose rows
    all fail the row gate (module docstring); 1 where none does.

    Parameters
    ----------
    epoch : railnav.filters.fault_detection.EpochScreen
        ``keys`` ``"<sv>/<kind>"``, ``innov`` (m,), ``S`` (m, m), at the prior.
    nis_threshold : float
        The screen's row gate on ``ν_i²/S_ii`` (dimensionless).
    """
    nu = np.asarray(epoch.innov, dtype=float)
    if nu.size < MIN_KIND_ROWS:
        return 1.0
    S = np.asarray(epoch.S, dtype=float)
    failing = nu * nu > nis_threshold * np.diagonal(S)
    if np.count_nonzero(failing) < MIN_KIND_ROWS:     # most epochs: stop here
        return 1.0
    kinds = np.array([key_kind(str(key)) for key in epoch.keys], dtype=object)
    tail = 1.0
    for kind in KINDS:
        rows = kinds == kind
        m = int(np.count_nonzero(rows))
        if m < MIN_KIND_ROWS or not failing[rows].all():
            continue
        *_, residual = common_offset(nu[rows], S[np.ix_(rows, rows)], np.ones(m, dtype=bool))
        tail = min(tail, chi2_sf(float(residual), m - 1))
    return tail
