r"""One GNSS channel's fault history: failures, drift test, influence, re-admission.

A channel is one satellite's pseudorange or its range rate (`railnav.filters.fault_detection`).
`Channel` keeps, while the channel is admitted,

* its recent row-test outcomes (excluded after `exclusion_failures` in
  `exclusion_window`);
* a two-sided CUSUM of its normalized innovations ``r = ν/√S`` (Page 1954), each
  increment clipped at the row test's threshold: ``C⁺ = max(0, C⁺ + r − δ)``,
  ``C⁻ = max(0, C⁻ − r − δ)``; excluded when either exceeds ``h``;
* its **influence**: the sum of the corrections its used rows made to the state,
  ``Σ K_i ν_i``, over each side's current CUSUM run (reset when that side returns to 0).
  On an exclusion by the drift test the influence of the alarming side is what the
  fault may have pulled into the state before it was caught; the screen adds its outer
  product to the prior covariance (`ekf.EpochRows`), so the remaining satellites can
  pull the state back instead of the filter keeping an error it no longer knows about
  (an exclusion for failed rows adds nothing: those rows were not used);

and, while excluded, its last `readmission_passes` normalized innovations: it is
re-admitted when all of them pass the row test and their mean is consistent with zero,
``|Σ r| / √N <= READMIT_MEAN_SIGMA`` (a ramp still running passes the row test now and
then, at 2–3σ, but not this).

A screen's channels are one `ChannelTable`: their states in arrays, one row a channel, so
an epoch whose rows all belong to admitted channels and pass the row test (most epochs)
steps all its channels in a few array operations (`ChannelTable.admitted_rows`,
`ChannelTable.add_influences`: elementwise, the numbers of the row-by-row methods, to the
bit); `Channel` is one channel's view of the table, stepped row by row (`RowScreen`'s
other epochs).
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np
import numpy.typing as npt

__all__ = ["Channel", "ChannelTable", "READMIT_MEAN_SIGMA"]

Array = npt.NDArray[np.float64]

#: Re-admission needs the mean normalized innovation of the passing run within this many
#: of its σ (two-sided 0.27 % of fault-free channels wait one more epoch).
READMIT_MEAN_SIGMA = 3.0


class ChannelTable:
    """The channels of one fault screen, keyed ``"<sv>/<kind>"`` (module docstring).

    A mapping of keys to `Channel` views (``in``, iteration, ``get``, ``[key]``,
    ``items``, ``values``); `ids` gives rows' channels, `admitted_rows` and
    `add_influences` step several at once.

    Parameters
    ----------
    config : railnav.filters.fault_config.FaultDetectionConfig
    n_states : int
        Size of the filter's state (for the influence); set before the first channel.
    """

    def __init__(self, config, n_states: int = 0) -> None:
        self.config, self.n_states = config, n_states
        self.index: dict[str, int] = {}
        self.n_excluded = 0
        self.passes: dict[int, deque] = {}       # excluded channels' passing runs
        self._grow(0)

    def _grow(self, n_used: int) -> None:
        """Room for more channels, the first `n_used` kept (new rows zero: a new
        channel's state; the influence `n_states` wide)."""
        window = 1 if self.config is None else self.config.exclusion_window
        cap = max(16, 2 * (n_used + 1))
        shapes = {"cusum": ((cap, 2), float), "influence": ((cap, 2, self.n_states), float),
                  "open": ((cap, 2), bool), "excluded": ((cap,), bool),
                  "drifted": ((cap,), bool), "failures": ((cap, window), bool),
                  "appended": ((cap,), np.intp)}
        for name, (shape, dtype) in shapes.items():
            new = np.zeros(shape, dtype=dtype)
            if n_used:
                new[:n_used] = getattr(self, name)[:n_used]
            setattr(self, name, new)

    def add(self, key: str) -> int:
        """The id of `key`'s channel, a new one (admitted, nothing recorded) if needed."""
        k = self.index.get(key)
        if k is None:
            k = len(self.index)
            if k == self.cusum.shape[0] or self.influence.shape[2] != self.n_states:
                self._grow(k)
            self.index[key] = k
        return k

    def ids(self, keys) -> npt.NDArray[np.intp]:
        """The channel id of each key (new channels added)."""
        get = self.index.get
        out = [get(key, -1) for key in keys]
        if -1 in out:
            out = [self.add(key) for key in keys]
        return np.array(out, dtype=np.intp)

    def __contains__(self, key) -> bool:
        return key in self.index

    def __iter__(self):
        return iter(self.index)

    def __len__(self) -> int:
        return len(self.index)

    def __getitem__(self, key: str) -> "Channel":
        return Channel(self, self.index[key])

    def get(self, key: str) -> "Channel | None":
        k = self.index.get(key)
        return None if k is None else Channel(self, k)

    def items(self):
        return ((key, Channel(self, k)) for key, k in self.index.items())

    def values(self):
        return (Channel(self, k) for k in self.index.values())

    def admitted_rows(self, ids: npt.NDArray[np.intp], r: Array, clip: float
                      ) -> npt.NDArray[np.bool_]:
        """`Channel.admitted_row` of each row (passed: not failed) of admitted channels
        `ids` (distinct), with normalized innovations `r`; True where the channel becomes
        excluded (by its drift test). The same numbers as row by row: each channel's are
        its own elementwise operations, in the same order."""
        cfg = self.config
        window = self.failures.shape[1]
        self.failures[ids, self.appended[ids] % window] = False
        self.appended[ids] += 1
        step = np.minimum(np.maximum(r, -clip), clip)     # NaN stays NaN, as row by row
        new = self.cusum[ids]                             # C± + (±step) − δ, each side
        new[:, 0] += step
        new[:, 1] -= step
        new -= cfg.drift_allowance
        new = np.where(new > 0.0, new, 0.0)               # (NaN: 0, as `up if up > 0.0`)
        ended = self.open[ids] & (new == 0.0)             # a side back at 0 ends its run
        if np.count_nonzero(ended):
            rows, sides = np.nonzero(ended)
            self.influence[ids[rows], sides] = 0.0
            self.open[ids[rows], sides] = False
        self.cusum[ids] = new
        h = cfg.drift_threshold
        if h is None:
            return np.zeros(ids.size, dtype=bool)
        drift = (new > h).any(axis=1)
        for k in ids[drift].tolist():
            self._exclude(k, True)
        return drift

    def add_influences(self, ids: npt.NDArray[np.intp], delta: Array) -> None:
        """`Channel.add_influence` of each row's correction ``delta[i]`` to channel
        ``ids[i]`` (distinct)."""
        open_now = self.cusum[ids] > 0.0
        if np.count_nonzero(open_now):
            rows, sides = np.nonzero(open_now)
            self.influence[ids[rows], sides] += delta[rows]
            self.open[ids[rows], sides] = True

    def _exclude(self, k: int, drift: bool) -> None:
        self.excluded[k], self.drifted[k] = True, drift
        self.n_excluded += 1
        self.passes.pop(k, None)


class Channel:
    """One channel of a `ChannelTable` (module docstring), stepped row by row.

    Parameters
    ----------
    table : ChannelTable
    k : int
        The channel's id in `table`.
    """

    __slots__ = ("table", "k")

    def __init__(self, table: ChannelTable, k: int) -> None:
        self.table, self.k = table, k

    @property
    def excluded(self) -> bool:
        return bool(self.table.excluded[self.k])

    @property
    def _cusum(self) -> list[float]:
        """``[C⁺, C⁻]``."""
        return self.table.cusum[self.k].tolist()

    @property
    def _influence(self) -> Array:
        """Each side's influence, shape (2, n) (a view)."""
        return self.table.influence[self.k]

    @property
    def _failures(self) -> list[bool]:
        """The recent row-test outcomes, oldest first."""
        t = self.table
        ring, n = t.failures[self.k], int(t.appended[self.k])
        window = ring.size
        if n <= window:
            return ring[:n].tolist()
        start = n % window
        return ring[start:].tolist() + ring[:start].tolist()

    def admitted_row(self, r: float, failed: bool, clip: float) -> bool:
        """Record a row of the admitted channel; True when the channel becomes excluded.

        Parameters
        ----------
        r : float
            Normalized innovation ``ν/√S``.
        failed : bool
            The row test failed (the row is rejected).
        clip : float
            The row test's threshold on ``|r|`` (``√config.nis_threshold``).
        """
        t, k = self.table, self.k
        cfg = t.config
        window = t.failures.shape[1]
        t.failures[k, t.appended[k] % window] = bool(failed)
        t.appended[k] += 1
        # min(max(r, -clip), clip) and max(0.0, ·) written out (NaN as NumPy's)
        step = -clip if r < -clip else (clip if r > clip else r)
        cusum = t.cusum[k].tolist()
        up = cusum[0] + step - cfg.drift_allowance
        down = cusum[1] - step - cfg.drift_allowance
        up, down = (up if up > 0.0 else 0.0), (down if down > 0.0 else 0.0)
        t.cusum[k] = (up, down)
        opened = t.open[k]                  # a side back at 0 ends its run's influence
        for side, value in ((0, up), (1, down)):
            if opened[side] and value == 0.0:
                t.influence[k, side] = 0.0
                opened[side] = False
        h = cfg.drift_threshold
        drift = h is not None and (up > h or down > h)
        if drift or (failed and np.count_nonzero(t.failures[k]) >= cfg.exclusion_failures):
            t._exclude(k, drift)
            return True
        return False

    def add_influence(self, delta_x: Array) -> None:
        """Add a used row's correction ``K_i ν_i`` (shape (n,)) to the open CUSUM runs
        (none: nothing to do)."""
        self.table.add_influences(np.array([self.k]), delta_x[None, :])

    def contamination(self) -> Array:
        """What the channel may have pulled into the state when its drift test excluded
        it: the influence of its larger CUSUM side, shape (n,); zeros when it was
        excluded for failed rows (those were not used)."""
        t, k = self.table, self.k
        if not t.drifted[k]:
            return np.zeros(t.influence.shape[2])
        return t.influence[k, int(np.argmax(t.cusum[k]))].copy()

    def excluded_row(self, r: float, failed: bool) -> bool:
        """Record a row of the excluded channel; True when it is re-admitted."""
        t, k = self.table, self.k
        passes = t.passes.get(k)
        if passes is None:
            passes = t.passes[k] = deque(maxlen=t.config.readmission_passes)
        if failed:
            passes.clear()
            return False
        passes.append(float(r))
        n = passes.maxlen
        if len(passes) < n or abs(sum(passes)) > READMIT_MEAN_SIGMA * math.sqrt(n):
            return False
        t.excluded[k] = t.drifted[k] = False
        t.n_excluded -= 1
        t.passes.pop(k, None)
        t.failures[k] = False
        t.appended[k] = 0
        t.cusum[k] = 0.0
        t.influence[k] = 0.0
        t.open[k] = False
        return True
