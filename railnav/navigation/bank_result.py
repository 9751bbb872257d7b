"""What parallel-track identification produces (`railnav.navigation.bank.navigate_tracks`).

`TrackBankResult` keeps each candidate track's `railnav.navigation.result.NavigationResult` and
the track probabilities after every cycle. `TrackBankResult.combined` is the run's one
navigation answer, what ``railnav run TRACK_A TRACK_B`` writes: at each stored time the
estimates of the filter on the most probable track, with the columns ``track`` (that
track's name, the file stem) and ``track_probability`` (its probability); the
innovations of each GNSS epoch are those of the filter on the track most probable then.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.navigation.result import NavigationResult

__all__ = ["TrackBankResult"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class TrackBankResult:
    """A run of one filter per candidate track.

    Attributes
    ----------
    names : tuple of str
        The candidate tracks' names (file stems), in the order of `results`.
    results : tuple of NavigationResult
        Each track's filter.
    bank : railnav.navigation.bank.TrackBankConfig
    start_gps_time_s : float
        GPS time of ``time_s = 0``, s.
    runtime_s : float
        Wall time, s.
    time_s : ndarray, shape (C,)
        End of each cycle (chunk), s from the trip start.
    probabilities : ndarray, shape (C, J)
        Track probabilities after each cycle.
    log_likelihoods : ndarray, shape (C, J)
        Each cycle's evidence (0 without a GNSS epoch, −inf for a stopped filter).
    common_rows : ndarray of int, shape (C,)
        GNSS rows the evidence was computed on (used by every filter).
    """

    names: tuple[str, ...]
    results: tuple[NavigationResult, ...]
    bank: object
    start_gps_time_s: float
    runtime_s: float
    time_s: Array
    probabilities: Array
    log_likelihoods: Array
    common_rows: npt.NDArray[np.int_]

    def final_probabilities(self) -> dict[str, float]:
        """The last cycle's probabilities by track name."""
        last = self.probabilities[-1] if len(self.time_s) else \
            np.full(len(self.names), 1.0 / len(self.names))
        return {name: float(p) for name, p in zip(self.names, last)}

    def probabilities_at(self, t: npt.ArrayLike) -> Array:
        """Probabilities of the latest cycle at or before each time (the prior ``1/J``
        before the first cycle), shape (N, J)."""
        t = np.asarray(t, dtype=float)
        k = np.searchsorted(self.time_s, t + 1e-9, side="right") - 1
        prior = np.full((1, len(self.names)), 1.0 / len(self.names))
        table = np.vstack([prior, self.probabilities])
        return table[k + 1]

    def probability_frame(self) -> pd.DataFrame:
        """``time_s, gps_time_s``, one column per track (its name) and ``common_rows``."""
        frame = pd.DataFrame({"time_s": self.time_s,
                              "gps_time_s": self.time_s + self.start_gps_time_s})
        for j, name in enumerate(self.names):
            frame[name] = self.probabilities[:, j]
        frame["common_rows"] = self.common_rows
        return frame

    def combined(self) -> NavigationResult:
        """The most probable track's filter at each time (module docstring)."""
        lengths = [r.time_s.size for r in self.results]
        base = self.results[int(np.argmax(lengths))]
        t = base.time_s
        prob = self.probabilities_at(t)
        alive = np.array([[k < n for n in lengths] for k in range(t.size)])
        best = np.argmax(np.where(alive, prob, -1.0), axis=1)
        rows = np.arange(t.size)
        estimates = base.estimates.copy()
        x, P = base.x.copy(), base.P.copy()
        for j, r in enumerate(self.results):
            pick = rows[best == j]
            if pick.size and r is not base:
                estimates.iloc[pick] = r.estimates.iloc[pick].to_numpy()
                x[pick], P[pick] = r.x[pick], r.P[pick]
        estimates["track"] = np.array(self.names, dtype=object)[best]
        estimates["track_probability"] = prob[rows, best]
        final = self.results[int(best[-1])]
        return replace(final, time_s=t, x=x, P=P, estimates=estimates,
                       innovations=self._innovations())

    def _innovations(self) -> pd.DataFrame:
        """Each epoch's rows from the filter on the track most probable at that epoch."""
        frames = [r.innovations for r in self.results]
        if not any(len(f) for f in frames):
            return frames[0]
        epochs = np.unique(np.concatenate([f["epoch"].to_numpy() for f in frames]))
        times = np.concatenate([f.groupby("epoch")["time_s"].first().reindex(epochs).to_numpy()
                                [:, None] for f in frames], axis=1)
        t_epoch = np.nanmax(times, axis=1)
        prob = self.probabilities_at(t_epoch)
        present = np.isfinite(times)
        best = np.argmax(np.where(present, prob, -1.0), axis=1)
        parts = [frames[j][frames[j]["epoch"].isin(epochs[best == j])] for j in range(len(frames))]
        out = pd.concat(parts, ignore_index=True).sort_values(["epoch"], kind="stable")
        pick = dict(zip(epochs, np.array(self.names, dtype=object)[best]))
        out["track"] = out["epoch"].map(pick)
        return out.reset_index(drop=True)
