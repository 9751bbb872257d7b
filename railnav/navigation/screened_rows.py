"""The fault screen's rows as the divergence monitor reads them
(`railnav.navigation.monitor.FilterMonitor`).

`ScreenKeyMasks` gives, for an epoch's screen keys (``"<sv>/<kind>"``), the rows the
rejected-row test counts and the position rows, cached while the keys stay the same (the
satellites change seldom). `screened_out` says whether the screen kept enough of the
position rows out of the update that the epoch's own fix must be solved from all its data.
"""
from __future__ import annotations

import numpy as np

from railnav.filters.fault_detection import key_kind
from railnav.filters.standstill_rows import STANDSTILL_ROW_KINDS

__all__ = ["POSITION_ROW_KINDS", "SCREENED_SHARE", "SCREENED_MIN_ROWS", "ScreenKeyMasks",
           "screened_out"]

#: The fault screen's kinds of those rows (`railnav.filters.common.ROW_KINDS`,
#: `railnav.filters.fix_rows.FIX_ROW_KINDS`).
POSITION_ROW_KINDS = ("pseudorange", "fix_along", "fix_cross", "fix_up")
#: The epoch's fix is solved from all its data (`screened_out`) when the fault screen kept
#: at least this share of the position rows, and this many (>= 1), out.
SCREENED_SHARE, SCREENED_MIN_ROWS = 0.25, 2


class ScreenKeyMasks:
    """The masks of one monitor's screen keys, the last key list's kept."""

    def __init__(self) -> None:
        self._last: tuple[list, tuple] | None = None

    def masks(self, keys) -> tuple:
        """``(counted, n_counted, position, n_position)`` of screen keys `keys`: the rows
        the rejected-row test counts, the position rows (`POSITION_ROW_KINDS`), and how
        many of each; computed when the keys differ from the last call's. Not counted: the
        standstill detector's (`STANDSTILL_ROW_KINDS`): their rejection refutes its guess,
        not the filter (a MEMS IMU cruising reads as standing; counted, the 5-min stop was
        ``degraded`` on 21 % of its epochs)."""
        names = keys.tolist() if isinstance(keys, np.ndarray) else list(keys)
        if self._last is not None and self._last[0] == names:
            return self._last[1]
        kinds = [key_kind(key) for key in names]
        counted = np.array([kind not in STANDSTILL_ROW_KINDS for kind in kinds], dtype=bool)
        position = np.array([kind in POSITION_ROW_KINDS for kind in kinds], dtype=bool)
        masks = (counted, int(np.count_nonzero(counted)), position,
                 int(np.count_nonzero(position)))
        self._last = (names, masks)
        return masks


def screened_out(last, masks: tuple) -> bool:
    """Whether the filter's fault screen (`railnav.filters.fault_detection.RowScreen`), in
    its epoch `last` (None: it did not run), kept `SCREENED_SHARE` of this epoch's position
    rows (at least `SCREENED_MIN_ROWS`) from the update: its choice was made at the prior,
    so the rows left are not independent of it (a filter far off keeps the rows that agree
    with it), and the epoch's fix is then solved from all its data. One satellite left out
    (its channel excluded over a stretch of epochs) leaves the snapshot to the others.
    `masks`: `ScreenKeyMasks.masks` of its keys."""
    if last is None:
        return False
    out_rows = ~last.used
    if not out_rows.any():                 # every row used: none out (SCREENED_MIN_ROWS)
        return False
    position, n_position = masks[2:]
    out = int(np.count_nonzero(position & out_rows))
    return out >= max(SCREENED_MIN_ROWS, SCREENED_SHARE * n_position)
