r"""Divergence monitor: is a filter still consistent with its data, and what to do when not.

`FilterMonitor` watches one track-based filter (states ``s``, ``v``) epoch by epoch while it
runs (`railnav.navigation.loop.ChunkLoop.monitored`) and gives each measurement epoch a
status, ``ok``, ``degraded`` or ``lost``, from windowed tests over the last
`MonitorConfig.window_epochs` epochs and one of the epoch alone. Each is a tail
probability of a χ² (or binomial) statistic that is exact when the filter's σ are right:

* **GNSS NIS**: the sum of the accepted rows' ``ν_i²/S_ii`` against χ² with one degree of
  freedom per row;
* **rejected rows**: the epochs with a row rejected by the fault screen (before the
  update: uncounted until issue 14, a filter rejecting every fix for 16 s said ``ok``) or
  the χ² row gate, against the binomial law of epochs whose ``m`` rows are each rejected
  with probability ``p_row`` (`tail_probabilities.row_false_rejection_p`, as the network
  run's): ``q = 1 − (1 − p_row)^m``; epochs, as a fix's rows are rejected together. A fix
  off the track (below) is rejected whatever the state: ``degraded``, never ``lost``;
* **fix disagreement**: ``d = (s_fix − s_prior)/√(σ_fix² + σ_s,prior²)`` of an independent
  single-epoch fix on the track at the epoch's prior (not yet updated with that epoch's
  measurements); ``Σ d²`` against χ²ₙ and the signed mean, ``(Σ d)²/n`` against χ²₁ (a
  filter off by a steady offset), the smaller tail doubled (Bonferroni). The fix is the
  epoch's own position rows (pseudoranges, or a fix's position rows) solved alone on the
  track, linearised at the prior (`railnav.navigation.snapshot.snapshot_fix`; a fix
  projected on the whole track, on the wrong pass of a ring, said ``lost`` on 160 of 280
  consistent epochs). Where the filter's fault screen kept some of those rows out
  of the update (a choice made at the prior, so the rows left are not independent of it),
  the fix is instead the run's position fix of the epoch (`track_fixes.fix_log_track_fixes`)
  or the receiver's single-point fix of that epoch, solved then (`track_fixes.spp_fix_at`),
  projected on the track near the prior (`track_fixes.TrackFixes.near`). With the slow code
  error's state the rows measure ``s + σ_e b``: σ_s,prior is then that sum's
  (`railnav.filters.code_bias.apparent_variance`);
* **pseudo-observation NIS**: the continuous (accelerometer) pseudo-observation's NIS
  summed over the window's steps against χ² with its total dimension;
* **a whole kind rejected** (``p_kind_rejected``, this epoch): where all (≥ 4) range rates,
  or pseudoranges, fail the fault screen's row gate at the prior, their NIS less one
  common offset (a receiver clock step) against χ²_{m−1} (`railnav.navigation.kind_rejection`:
  six range rates rejected at 56σ had left the rejected-row test at p = 1);
* **fix disagreement too small** (``p_fix_small``, ``degraded`` only,
  `railnav.navigation.small_disagreement`): the lower χ² tail of ``Σ δs²/σ²_fix`` over the
  last `MonitorConfig.small_window_epochs` epochs, with the fixes' own σ (not floored),
  over the epochs where fixes sharing one error could take the prior beyond its own σ.
  Fixes that agree with the filter far better than their σ say are better than it or
  correlated with it: slow multipath the filter has followed, its σ built as if the
  errors were independent and too small. On the urban drive this is what flags the
  fix-based filter's steady 2-5 m along-track errors at σ_s 0.6 m (leg 1: 134 of 157 such
  epochs unflagged without it, 7 with it). It cannot tell fixes better than their σ that
  the filter averaged (they fail it too), but neither a prior better than its σ nor fixes
  each of which resets the filter fail it (stop 36: the three carrier-fixed Brussels logs
  were ``degraded`` on 2478 of 2480 epochs by it, now on 92, all in log_28554's tunnel,
  where the receiver's propagated positions at σ 10 m are averaged).
  It is off for a filter that inflates its rows for correlated errors
  (``pseudorange_inflation`` ≠ 1: the gnss-only filter on real data, its pseudoranges, and
  its code fixes with ``FixModelConfig.correlated_code_errors``: `fix_inflation`): there
  its fixes are correlated with it by the filter's own model, and the test fired on every
  epoch (the fix-based filter ``degraded`` on 406 of 407 epochs of leg 1, fixes inflated).

Thresholds: a test *fails at level p* when its tail probability is below ``p``. The status is
``lost`` when the fix-disagreement test fails at `MonitorConfig.p_lost` (1e-6) without the
window's largest ``d²`` (one fix cannot tell its own fault from the filter's: on log_29083
a fix 41 m, 13σ, ahead restarted the filter from it at speed 0 ± 50 m/s, 300 m off for
16 s; never larger, that statistic keeps false ``lost`` below p_lost), or the whole-kind
test fails at p_lost, or the rejected-row test does (fixes on the track) and at least
`MonitorConfig.lost_rejected_share` of the window's rows were rejected; ``degraded`` when
any test fails at `MonitorConfig.p_degraded` (1e-3; the fix test over the whole window),
else ``ok``. For a consistent filter the false ``degraded`` rate is ≤ 7·p_degraded
per epoch (two kinds), false ``lost`` ≤ 4·p_lost; the windows overlap: alarms come in runs.

The statuses and the status in force at a time (`status_at`) are
`railnav.navigation.statuses`'s (re-exported here).

Recovery (`MonitorConfig.recover`, `railnav.navigation.monitor_recovery`): when ``lost``,
the state is re-initialised from the epoch's fix or its ``s, v`` covariance widened.
After a recovery the windows restart, and the status is ``degraded`` until
`MonitorConfig.min_epochs` epochs have been seen again.

A fix farther from the track than the χ²₁ quantile of `MonitorConfig.p_lost` of its own
cross-track σ (floored at `MonitorConfig.min_fix_sigma_m`; `TrackFixes.off_track`) is not a
position on this track (a receiver's jump: log 29083 of the Brussels logs jumps 90-200 m
off it): the monitor neither tests the filter against it nor restarts from it.

Real-data caveat: urban SPP errors are correlated from epoch to epoch (multipath): the fix
test is heavier-tailed than χ²ₙ; the fix σ are floored at `MonitorConfig.min_fix_sigma_m`.
The figures on the urban drive are in ``benchmarks/results/real_pieces.json``.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.filters.code_bias import apparent_variance
from railnav.filters.gnss_only_model import CODE_BIAS_STATE
from railnav.filters.ins_clock_model import clock_offset_columns
from railnav.navigation.kind_rejection import kind_rejected_tail
from railnav.navigation.monitor_config import MonitorConfig
from railnav.navigation.monitor_recovery import reinitialised, widened
from railnav.navigation.small_disagreement import SmallDisagreement
from railnav.navigation.screened_rows import ScreenKeyMasks, screened_out
from railnav.navigation.snapshot import snapshot_fix
from railnav.filters.row_sets import ROW_STATUSES
from railnav.navigation.statuses import STATUSES, status_at
from railnav.navigation.tail_probabilities import (
    binom_sf,
    chi2_isf,
    chi2_sf,
    fix_disagreement_tail,
    row_false_rejection_p,
    sigma_gate,
)
from railnav.navigation.track_fixes import TrackFixes

__all__ = ["FilterMonitor", "STATUSES", "status_at"]

Array = npt.NDArray[np.float64]

#: The window's per-epoch quantities, rows of `FilterMonitor`'s window array: accepted
#: GNSS rows' NIS sum and count, rejected rows, fix disagreement ``d²`` (floored σ; NaN
#: without a fix), pseudo-observation NIS sum and dimension, ``d``, whether any row was
#: rejected (by the fault screen or the gate), the same for a fix on the track (or rows
#: with no fix to place), and the epoch's rows.
_NIS, _N_ACC, _N_REJ, _D2, _NISC, _NISC_DOF, _D, _E_REJ, _E_REJ_ON, _ROWS = range(10)


def _sqrt(value: float) -> float:
    """``np.sqrt`` of a Python float, as a Python float, without NumPy's scalar call: the
    same bits (IEEE's correctly rounded square root), NaN below 0."""
    return math.sqrt(value) if value >= 0.0 else math.nan


class FilterMonitor:
    """Status of one filter epoch by epoch, and its recovery (module docstring).

    The windows are arrays that hold the last epochs' quantities in time order (the sums
    over them are NumPy's sums of the same numbers in the same order as over a list of
    them: the same bits); the tails of an epoch are one SciPy call each.

    Parameters
    ----------
    layout : ekf.StateLayout
        With ``s`` and ``v``.
    fixes : TrackFixes or None
        The run's position fixes on the track: the fix test's fix where the epoch's own
        rows cannot give one (`snapshot_fix`, `screened_rows.screened_out`), and a restart's.
    config : railnav.navigation.monitor_config.MonitorConfig
    gate_probability : float or None
        The run's χ² row gate (None: the rejected-row test is off).
    fix_at : callable(time_s) -> TrackFixes or None, optional
        Without `fixes`: the epoch's single-point fix, solved when needed
        (`railnav.navigation.track_fixes.spp_fix_at`).
    screen : railnav.filters.fault_detection.RowScreen, optional
        The filter's fault screen (read only: which rows it kept out).
    pseudorange_inflation : float
        The filter's pseudorange variance factor for correlated errors (`snapshot_fix`).
    """

    def __init__(self, layout, fixes: TrackFixes | None, config: MonitorConfig,
                 gate_probability: float | None, *,
                 fix_at: Callable[[float], TrackFixes | None] | None = None,
                 screen=None, pseudorange_inflation: float = 1.0) -> None:
        self.layout, self.fixes, self.config = layout, fixes, config
        self.pseudorange_inflation = float(pseudorange_inflation)
        self.fix_at, self.screen = fix_at, screen
        self._screened = None if screen is None or not screen.epochs else screen.epochs[-1]
        self._gate = getattr(getattr(screen, "config", None), "nis_threshold", None)
        self._kind_tail = 1.0                  # this epoch's whole-kind test (`prior`)
        self.i_s, self.i_v = layout.index("s"), layout.index("v")
        self.p_reject = row_false_rejection_p(gate_probability, self._gate)
        # no statistic below this fails the fix test without its worst epoch (`_status`
        # skips it there): 0.9 of χ²₁'s quantile of p_lost/2 (a χ² tail grows with dof)
        self._lost_below = 0.9 * chi2_isf(config.p_lost / 2.0, 1)
        self._screen_rows = (0, 0)             # this epoch's screened rows, rejected
        self._prior: tuple[float, float, float] | None = None
        self._snapshot: tuple[float, float] | None = None
        self._epoch_fixes: TrackFixes | None = None
        self._clock_columns = clock_offset_columns(layout)
        self.i_bias = layout.index(CODE_BIAS_STATE) if CODE_BIAS_STATE in layout.names \
            else None
        # the screen keys' masks, the last key list's kept
        self._key_masks = ScreenKeyMasks()
        # the last epochs, oldest first, in the last `_n_window` columns
        self._window = np.full((_ROWS + 1, config.window_epochs), np.nan)
        self._n_window = 0
        self.small = SmallDisagreement(config.small_window_epochs)     # ``p_fix_small``
        self._seen = 0
        self.records: list[dict] = []

    def prior(self, time_s: float, x: Array, P: Array, observations=None) -> None:
        """The prior of the epoch at `time_s` (before its update), and the rows the filter
        updates it with (`snapshot_fix` solves this epoch's fix on the track from them)."""
        self._prior = (float(time_s), float(x[self.i_s]), float(P[self.i_s, self.i_s]))
        last = None if observations is None else self._new_screen_epoch()
        masks = None if last is None else self._key_masks.masks(last.keys)
        # the screen's rows and rejected rows that the rejected-row test counts
        self._screen_rows = (0, 0) if last is None else (masks[1], int(np.count_nonzero(
            masks[0] & (last.status == ROW_STATUSES[1]))))
        if last is not None and self._gate is not None:
            self._kind_tail = kind_rejected_tail(last, self._gate)
        self._snapshot = None if observations is None or screened_out(last, masks) \
            else snapshot_fix(observations, x, self.i_s, self._clock_columns,
                              pseudorange_inflation=self.pseudorange_inflation)
        if self._snapshot is not None and self.i_bias is not None:
            self._prior = self._prior[:2] + (
                apparent_variance(observations, x, P, self.i_s, self.i_bias),)

    def _new_screen_epoch(self):
        """The fault screen's epoch (`railnav.filters.fault_detection.EpochScreen`) if the
        screen ran since the last call, else None."""
        last = None if self.screen is None or not self.screen.epochs else self.screen.epochs[-1]
        if last is None or last is self._screened:     # the screen did not run this epoch
            return None
        self._screened = last
        return last

    def epoch(self, chunk, x: Array, P: Array) -> tuple[Array, Array] | None:
        """Test the epoch that ended `chunk` (an `ekf.FilterResult`), posterior ``x, P``.

        Returns
        -------
        (x, P) or None
            The recovered state and covariance, or None to keep the filter's.
        """
        if chunk.t_d.size == 0 or self._prior is None:
            return None
        time_s, s_prior, var_prior = self._prior
        self._prior = None
        nis = chunk.innov_d ** 2 / chunk.s_d
        acc = np.asarray(chunk.accepted, dtype=bool)
        d = math.nan
        j = None if self.fixes is None else self.fixes.at(time_s)
        # a fix off the track (a receiver's jump) is rejected whatever the state
        on_track = j is None or self._on_track(self.fixes, j) is not None
        snapshot, self._snapshot = self._snapshot, None
        kind_tail, self._kind_tail = self._kind_tail, 1.0
        small = math.nan                               # `SmallDisagreement.term`, if any
        if snapshot is not None:                       # this epoch's own rows, on the track
            ds, var_fix, white = snapshot
            small = self.small.term(ds, var_fix, var_prior) if white else math.nan
            var_fix = max(var_fix, self.config.min_fix_sigma_m ** 2)
            d = ds / _sqrt(var_fix + var_prior)
        else:                                          # a fix from all the epoch's data
            fixes = self.fixes
            if j is None and self.fix_at is not None:
                fixes = self.fix_at(time_s)
                j = None if fixes is None else fixes.at(time_s)
            j = self._on_track(fixes, j)
            if j is not None:
                s_fix, sigma_fix = fixes.near(j, s_prior)
                # a filter that inflates its rows for correlated errors (its code fixes
                # too) is correlated with this fix: no lower tail (`SmallDisagreement`)
                small = self.small.term(s_fix - s_prior, sigma_fix ** 2, var_prior) \
                    if self.pseudorange_inflation == 1.0 else math.nan
                var_fix = max(sigma_fix, self.config.min_fix_sigma_m) ** 2
                d = (s_fix - s_prior) / _sqrt(var_fix + var_prior)
                self._epoch_fixes = fixes
        self._push_epoch(chunk, nis, acc, d, on_track, small)
        self._seen += 1
        status, tails = self._status(kind_tail)
        record = {"time_s": time_s, "status": status, **tails,
                  "sigma_s_prior_m": _sqrt(var_prior), "action": ""}
        self.records.append(record)
        if status != "lost" or not self.config.recover:
            return None
        far = math.isfinite(d) and d * d > chi2_isf(self.config.p_lost, 1)
        fixes, self._epoch_fixes = self._epoch_fixes or self.fixes, None
        if far and j is None and self.fix_at is not None:   # solved now, for the restart
            fixes = self.fix_at(time_s)
            j = self._on_track(fixes, None if fixes is None else fixes.at(time_s))
        far = far and j is not None
        recovered = (reinitialised(fixes, j, x, P, self.i_s, self.i_v, self.config) if far
                     else widened(x, P, self.i_s, self.i_v,
                                  self._window[_D2, self._window.shape[1] - self._n_window:]))
        record["action"] = "reinit" if far else "widen"
        self._n_window = 0                             # the windows restart
        self.small.restart()
        self._seen = 0
        return recovered

    def _on_track(self, fixes: TrackFixes | None, j: int | None) -> int | None:
        """`j`, or None where fix `j` lies off the track beyond the χ²₁ quantile of
        `MonitorConfig.p_lost` of its cross-track σ (floored at
        `MonitorConfig.min_fix_sigma_m`; `TrackFixes.off_track`): a receiver's jump, not a
        position on the track, neither tested against the filter nor restarted from."""
        if j is None or not fixes.off_track(j, floor_m=self.config.min_fix_sigma_m,
                                            gate_sigma=sigma_gate(self.config.p_lost)):
            return j
        return None

    def _push_epoch(self, chunk, nis: Array, acc, d: float, on_track: bool, small: float
                    ) -> None:
        """Push the epoch's quantities: its rows' (`acc`: which the gate accepted) and the
        fault screen's rejections (`prior`), the fix disagreement `d` (NaN: none), and
        whether its fix is on the track."""
        n_acc = int(np.count_nonzero(acc))
        screened, n_screen_rej = self._screen_rows
        self._screen_rows = (0, 0)
        n_rej = acc.size - n_acc + n_screen_rej        # the gate's and the screen's
        self._push(float(np.add.reduce(nis[acc])), n_acc, n_rej, d * d,
                   float(chunk.nis_c_sum),
                   int(chunk.nis_c_count) * max(chunk.innov_c.shape[-1], 1)
                   if chunk.innov_c.ndim == 2 else 0, d, float(n_rej > 0),
                   float(n_rej > 0 and on_track), float(max(screened, acc.size)), small=small)

    def _push(self, *row: float, small: float) -> None:
        """Append one epoch's quantities (`_NIS` ... `_D`) and its lower-tail term
        (`SmallDisagreement.term`) to the windows, the oldest dropped."""
        w = self._window
        w[:, :-1] = w[:, 1:]
        w[:, -1] = row
        self._n_window = min(self._n_window + 1, w.shape[1])
        self.small.push(small)

    def _status(self, kind_tail: float) -> tuple[str, dict]:
        w = self._window[:, self._window.shape[1] - self._n_window:]   # (10, n), oldest first
        # (the sums of ndarray.sum, here and below: np.add.reduce, without the wrappers;
        # Python floats after, each the float64 it was)
        nis_sum, n_acc, n_rej, d2_all, nisc, nisc_dof, d_all, e_rej, e_rej_on, _ = \
            np.add.reduce(w, axis=1).tolist()
        n_rows = n_acc + n_rej
        rejected_share = n_rej / n_rows if n_rows else 0.0
        if math.isfinite(d2_all):      # a fix every epoch (d² >= 0): the rows as they are,
            # their axis sums (each the bits of the row's own)
            n_have, have_last, d2, d, d2_sum, d_sum = w.shape[1], True, w[_D2], w[_D], \
                d2_all, d_all
        else:
            have = np.isfinite(w[_D2])
            n_have, have_last = int(np.count_nonzero(have)), bool(have[-1])
            d2, d = w[_D2][have], w[_D][have]
            d2_sum, d_sum = float(np.add.reduce(d2)), float(np.add.reduce(d))
        p_fix = fix_disagreement_tail(d2_sum, d_sum, n_have)
        if n_have >= 2:                # `lost` only if the others fail without the worst
            k = int(d2.argmax())
            d2_rest, d_rest = d2_sum - float(d2[k]), d_sum - float(d[k])
            p_fix_lost = fix_disagreement_tail(d2_rest, d_rest, n_have - 1) if max(
                d2_rest, d_rest ** 2 / (n_have - 1)) >= self._lost_below else 1.0
        else:
            p_fix_lost = 1.0
        p_rejected = p_rejected_on = 1.0
        if self.p_reject is not None:                  # epochs, not rows (docstring)
            n_epochs = int(np.count_nonzero(w[_ROWS] > 0))
            q = 1.0 - (1.0 - self.p_reject) ** float(np.maximum.reduce(w[_ROWS]))
            p_rejected = binom_sf(int(e_rej), n_epochs, q)
            p_rejected_on = binom_sf(int(e_rej_on), n_epochs, q)
        tails = {"p_gnss_nis": chi2_sf(nis_sum, n_acc),
                 "p_rejected": p_rejected,
                 "p_fix": p_fix,
                 "p_pseudo_nis": chi2_sf(nisc, nisc_dof),
                 "p_fix_small": self.small.tail(),
                 "p_kind_rejected": kind_tail,
                 "fix_disagreement_sigma": math.sqrt(w[_D2, -1]) if have_last else np.nan,
                 "variance_factor": d2_sum / n_have if n_have else np.nan}
        cfg = self.config
        if min(p_fix_lost, kind_tail) < cfg.p_lost or (
                p_rejected_on < cfg.p_lost and rejected_share >= cfg.lost_rejected_share):
            return "lost", tails
        if min(tails["p_gnss_nis"], p_rejected, p_fix, tails["p_pseudo_nis"], tails[
                "p_fix_small"], kind_tail) < cfg.p_degraded or self._seen < cfg.min_epochs:
            return "degraded", tails
        return "ok", tails

    def frame(self) -> pd.DataFrame:
        """One row per tested epoch: ``time_s, status``, the tests' tail probabilities,
        the fix disagreement (σ), the window's fix variance factor ``Σ d²/n``, the prior
        σ_s and the recovery ``action`` (``reinit``, ``widen`` or empty)."""
        return pd.DataFrame.from_records(self.records, columns=[
            "time_s", "status", "p_gnss_nis", "p_rejected", "p_fix", "p_pseudo_nis",
            "p_fix_small", "p_kind_rejected",
            "fix_disagreement_sigma", "variance_factor", "sigma_s_prior_m", "action"])
