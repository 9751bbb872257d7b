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
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np
import numpy.typing as npt

__all__ = ["Channel", "READMIT_MEAN_SIGMA"]

Array = npt.NDArray[np.float64]

#: Re-admission needs the mean normalized innovation of the passing run within this many
#: of its σ (two-sided 0.27 % of fault-free channels wait one more epoch).
READMIT_MEAN_SIGMA = 3.0


class Channel:
    """A channel's history (module docstring).

    Parameters
    ----------
    config : railnav.filters.fault_config.FaultDetectionConfig
    n_states : int
        Size of the filter's state (for the influence).
    """

    def __init__(self, config, n_states: int) -> None:
        self.config = config
        self.excluded = False
        self._drifted = False
        self._failures: deque = deque(maxlen=config.exclusion_window)
        self._passes: deque = deque(maxlen=config.readmission_passes)
        self._cusum = [0.0, 0.0]
        self._influence = np.zeros((2, n_states))
        self._open = [False, False]    # influence added to the side since it was last reset

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
        cfg = self.config
        self._failures.append(bool(failed))
        # min(max(r, -clip), clip) and max(0.0, ·) written out (the same numbers, without
        # the calls: this runs for every row)
        step = -clip if r < -clip else (clip if r > clip else r)
        up = self._cusum[0] + step - cfg.drift_allowance
        down = self._cusum[1] - step - cfg.drift_allowance
        up, down = (up if up > 0.0 else 0.0), (down if down > 0.0 else 0.0)
        self._cusum = [up, down]
        opened = self._open                 # a side back at 0 ends its run's influence
        if opened[0] and up == 0.0:
            self._influence[0] = 0.0
            opened[0] = False
        if opened[1] and down == 0.0:
            self._influence[1] = 0.0
            opened[1] = False
        h = cfg.drift_threshold
        drift = h is not None and (up > h or down > h)
        if drift or (failed and sum(self._failures) >= cfg.exclusion_failures):
            self.excluded, self._drifted = True, drift
            self._passes.clear()
            return True
        return False

    def add_influence(self, delta_x: Array) -> None:
        """Add a used row's correction ``K_i ν_i`` (shape (n,)) to the open CUSUM runs
        (none: nothing to do)."""
        up, down = self._cusum
        if up > 0.0:
            self._influence[0] += delta_x
            self._open[0] = True
        if down > 0.0:
            self._influence[1] += delta_x
            self._open[1] = True

    def contamination(self) -> Array:
        """What the channel may have pulled into the state when its drift test excluded
        it: the influence of its larger CUSUM side, shape (n,); zeros when it was
        excluded for failed rows (those were not used)."""
        if not self._drifted:
            return np.zeros(self._influence.shape[1])
        return self._influence[int(np.argmax(self._cusum))].copy()

    def excluded_row(self, r: float, failed: bool) -> bool:
        """Record a row of the excluded channel; True when it is re-admitted."""
        if failed:
            self._passes.clear()
            return False
        self._passes.append(float(r))
        n = self._passes.maxlen
        if len(self._passes) < n or abs(sum(self._passes)) > READMIT_MEAN_SIGMA * math.sqrt(n):
            return False
        self.excluded = False
        self._failures.clear()
        self._cusum = [0.0, 0.0]
        self._influence[:] = 0.0
        self._open = [False, False]
        return True
