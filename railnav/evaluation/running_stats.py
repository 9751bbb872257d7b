"""`railnav.evaluation.metrics.summarize`, accumulated over errors that arrive in blocks.

A streamed run (`railnav.navigation.streaming`) cannot keep its whole `ErrorSeries`: each block of
stored samples is added to a `RunningSummary` and forgotten. The running sums give the
same figures as `summarize` of the whole series: RMS from the sum of squares and the
count of finite values, maxima of |error|, each outage's value at its last stored sample
(a later block inside the outage replaces it) and its maximum, and the NEES mean.
Blocks must come in time order without repeated samples. `RunningCounts` counts the
filter's work (steps, GNSS epochs and rows, NIS) the same way.
"""
from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from ekf.history import FilterResult
from railnav.evaluation.metrics import ERROR_QUANTITIES, ErrorSeries

__all__ = ["RunningSummary", "RunningCounts"]

Array = npt.NDArray[np.float64]


class _Moments:
    """Sum of squares, count and max |x| of the finite values seen, per quantity."""

    def __init__(self) -> None:
        self.sum_sq = {q: 0.0 for q in ERROR_QUANTITIES}
        self.count = {q: 0 for q in ERROR_QUANTITIES}
        self.max = {q: -math.inf for q in ERROR_QUANTITIES}

    def add(self, errors: ErrorSeries, mask: npt.NDArray[np.bool_]) -> None:
        for q in ERROR_QUANTITIES:
            x = getattr(errors, q)[mask]
            x = x[np.isfinite(x)]
            if x.size:
                self.sum_sq[q] += float(np.dot(x, x))
                self.count[q] += int(x.size)
                self.max[q] = max(self.max[q], float(np.max(np.abs(x))))

    def stats(self, q: str) -> dict[str, float | None]:
        if self.count[q] == 0:
            return {"rms": None, "max": None}
        return {"rms": math.sqrt(self.sum_sq[q] / self.count[q]), "max": self.max[q]}

    def block(self) -> dict:
        return {q: self.stats(q) for q in ERROR_QUANTITIES}


class RunningSummary:
    """Accumulates the `summarize` figures of consecutive error blocks.

    Parameters
    ----------
    window : (start_s, end_s), optional
        A user window, s from the trip start.
    outages : sequence of (start_s, duration_s)
        GNSS outages, s from the trip start.
    """

    def __init__(self, *, window: tuple[float, float] | None = None, outages=()) -> None:
        self.window = window
        self.outages = tuple((float(a), float(b)) for a, b in outages)
        self._all, self._window = _Moments(), _Moments()
        self._outage_moments = [_Moments() for _ in self.outages]
        self._outage_end: list[dict | None] = [None] * len(self.outages)
        self._nees_sum, self._nees_count, self._nees_dof = 0.0, 0, 0
        self.samples = 0

    def add(self, errors: ErrorSeries) -> None:
        """Add the next block (stored samples after those already added)."""
        t = errors.time_s
        self.samples += int(t.size)
        self._all.add(errors, np.ones(t.size, dtype=bool))
        if self.window is not None:
            self._window.add(errors, (t >= self.window[0]) & (t <= self.window[1]))
        for k, (start, duration) in enumerate(self.outages):
            mask = (t >= start) & (t < start + duration)
            inside = np.flatnonzero(mask)
            if inside.size == 0:
                continue
            self._outage_moments[k].add(errors, mask)
            last = inside[-1]
            self._outage_end[k] = {"end_sample_s": float(t[last]), "at_end": {
                q: _finite(getattr(errors, q)[last]) for q in ERROR_QUANTITIES}}
        finite = errors.nees[np.isfinite(errors.nees)]
        self._nees_sum += float(finite.sum())
        self._nees_count += int(finite.size)
        self._nees_dof = errors.nees_dof

    def summary(self) -> dict:
        """The `railnav.evaluation.metrics.summarize` dictionary of everything added."""
        out: dict = {"all": self._all.block()}
        if self.window is not None:
            out["window"] = {"start_s": float(self.window[0]), "end_s": float(self.window[1]),
                             **self._window.block()}
        rows = []
        for (start, duration), moments, end in zip(self.outages, self._outage_moments,
                                                    self._outage_end):
            if end is None:
                continue
            rows.append({"start_s": start, "duration_s": duration,
                         "end_sample_s": end["end_sample_s"], "at_end": end["at_end"],
                         "max": {q: moments.stats(q)["max"] for q in ERROR_QUANTITIES}})
        out["outages"] = rows
        out["nees"] = {"mean": self._nees_sum / self._nees_count if self._nees_count else None,
                       "dof": self._nees_dof}
        return out


class RunningCounts:
    """Counters of a streamed filter's work for ``summary.json``: steps (set by the caller
    from the engine's progress), GNSS epochs and rows, rejected rows, continuous and GNSS
    row NIS sums, and the first and last stored times, s."""

    def __init__(self) -> None:
        self.steps = self.epochs = self.rows = self.rejected = 0
        self.nis_c_sum, self.nis_c_count = 0.0, 0
        self.nis_rows_sum, self.nis_rows_count = 0.0, 0
        self.first_time_s = self.last_time_s = math.nan

    def add(self, result: FilterResult) -> None:
        """Add the counts of the next block of results (`ekf.FilterResult`)."""
        self.nis_c_sum += result.nis_c_sum
        self.nis_c_count += result.nis_c_count
        self.epochs += int(result.t_d.size)
        self.rows += int(result.innov_d.size)
        self.rejected += int((~result.accepted).sum())
        if result.innov_d.size:
            nis = result.innov_d[result.accepted] ** 2 / result.s_d[result.accepted]
            self.nis_rows_sum += float(nis.sum())
            self.nis_rows_count += int(nis.size)
        if result.t.size:
            if not math.isfinite(self.first_time_s):
                self.first_time_s = float(result.t[0])
            self.last_time_s = float(result.t[-1])

    def statistics(self) -> dict:
        """The ``statistics`` block of ``summary.json`` (means None without samples)."""
        def mean(total: float, n: int):
            return total / n if n else None
        return {"nis_continuous_mean": mean(self.nis_c_sum, self.nis_c_count),
                "gnss_epochs": self.epochs, "gnss_rows": self.rows,
                "gnss_rows_rejected": self.rejected,
                "nis_gnss_rows_mean": mean(self.nis_rows_sum, self.nis_rows_count)}


def _finite(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None
