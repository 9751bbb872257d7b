"""An observation table cut into epochs: `split_epochs` and the epoch it gives.

`split_epochs` selects the ephemerides of a whole measurement table once
(`gnss_obs.ephemeris.select_ephemeris`) and cuts it into `EpochData`, whose columns are
`EpochColumns`: views of the table's rows, sliced when read. `whole_table` recognizes a
list of such epochs that covers one table whole and in order (so that a pass over all
epochs can use the table's columns as they are:
`gnss_obs.transmission.transmit_states_batch`).
The per-epoch preparation of these epochs at a receiver guess is `gnss_obs.epoch`.
"""
from __future__ import annotations

import logging
from collections.abc import MutableMapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from gnss_obs.ephemeris import select_ephemeris
from gnss_obs.measurements import MeasurementConfig

__all__ = ["EpochColumns", "EpochData", "split_epochs", "whole_table"]

log = logging.getLogger(__name__)


class EpochColumns(MutableMapping):
    """Columns of one epoch: rows ``[start, stop)`` of a whole table's columns, sliced when
    read (`split_epochs` cuts a file into hundreds of epochs of ~45 columns, of which the
    per-epoch preparation reads a few); a column assigned to it replaces its slice.

    Parameters
    ----------
    table : dict of str to ndarray
        The whole table's columns (not copied; never modified).
    start, stop : int
        The epoch's rows.
    """

    __slots__ = ("table", "start", "stop", "_own")

    def __init__(self, table: dict[str, np.ndarray], start: int, stop: int) -> None:
        self.table, self.start, self.stop = table, int(start), int(stop)
        self._own: dict[str, np.ndarray] = {}

    def __getitem__(self, key: str) -> np.ndarray:
        own = self._own
        if own and key in own:
            return own[key]
        return self.table[key][self.start:self.stop]

    def __setitem__(self, key: str, value: np.ndarray) -> None:
        self._own[key] = value

    def __delitem__(self, key: str) -> None:
        raise TypeError("epoch columns cannot be deleted")

    def __iter__(self):
        yield from self.table
        yield from (k for k in self._own if k not in self.table)

    def __len__(self) -> int:
        return len(self.table) + sum(k not in self.table for k in self._own)

    @property
    def is_view(self) -> bool:
        """No column was assigned: the epoch reads its table's rows only."""
        return not self._own


@dataclass(frozen=True)
class EpochData:
    """Measurements of one epoch with their selected ephemerides (aligned rows; the
    mappings of `split_epochs` are `EpochColumns`)."""

    gps_time_s: float
    meas: dict[str, np.ndarray]
    eph: dict[str, np.ndarray]

    def __len__(self) -> int:
        return len(self.meas["sv"])


def split_epochs(meas: pd.DataFrame, records: dict[str, pd.DataFrame],
                 config: MeasurementConfig) -> list[EpochData]:
    """Select ephemerides for a whole measurement table once and cut it into epochs.

    Parameters
    ----------
    meas : pandas.DataFrame
        `select_measurements` output, sorted by time.
    records : dict of str to pandas.DataFrame
        `RinexNav.records`.
    config : MeasurementConfig

    Returns
    -------
    list of EpochData
        One per distinct ``gps_time_s`` in time order; satellites without a valid
        ephemeris are left out (counted in the log).
    """
    eph = select_ephemeris(records, meas["sv"].to_numpy(), meas["gps_time_s"].to_numpy(),
                           galileo_message=config.galileo_message)
    ok = eph["ephemeris_ok"].to_numpy()
    if not ok.all():
        missing = sorted(set(meas["sv"].to_numpy()[~ok]))
        log.warning("%d of %d measurements have no valid ephemeris (%s)", (~ok).sum(), ok.size,
                    " ".join(missing))
    meas_cols = {c: meas[c].to_numpy()[ok] for c in meas.columns}
    eph_cols = {c: eph[c].to_numpy()[ok] for c in eph.columns}
    t = meas_cols["gps_time_s"]
    edges = np.flatnonzero(np.diff(t)) + 1
    bounds = zip(np.r_[0, edges].tolist(), np.r_[edges, t.size].tolist())
    return [EpochData(float(t[a]), EpochColumns(meas_cols, a, b), EpochColumns(eph_cols, a, b))
            for a, b in bounds]


def whole_table(epochs: list[EpochData]) -> tuple[dict, dict] | None:
    """The columns of the one table that `epochs` cut whole and in order, unmodified
    (`split_epochs`), or None."""
    first = epochs[0]
    if not (isinstance(first.meas, EpochColumns) and isinstance(first.eph, EpochColumns)):
        return None
    meas, eph, row = first.meas.table, first.eph.table, 0
    for e in epochs:
        m, p = e.meas, e.eph
        if not (isinstance(m, EpochColumns) and isinstance(p, EpochColumns)
                and m.table is meas and p.table is eph and m.is_view and p.is_view
                and m.start == row and p.start == row and p.stop == m.stop):
            return None
        row = m.stop
    if row != len(meas["gps_time_s"]) or row != len(next(iter(eph.values()))):
        return None
    return meas, eph
