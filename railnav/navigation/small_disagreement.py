r"""The divergence monitor's lower-tail fix test (``p_fix_small``,
`railnav.navigation.monitor`): fixes that agree with the filter far better than their σ say.

Such fixes are better than their σ (harmless: the filter built from them is conservative)
or share an error with the filter's prior (slow multipath the filter has followed: its σ,
built as if the fixes were independent, too small). The disagreement alone cannot tell
the two apart, nor can its high-pass part: on leg 1 of the urban drive the SPP fixes'
along-track errors, 2.4 m RMS at a median σ of 2.7 m, change by 0.6 m RMS from one second
to the next, as fixes better than their σ would. The test is built so that the harmless
causes the monitor *can* tell apart do not fail it, without a tuned constant:

* **The fix's own σ.** The term of an epoch is ``δs²/σ²_fix`` with ``δs = s_fix − s_prior``
  (σ_fix not floored). A fix independent of the prior gives ``δs`` a variance
  ``σ²_fix + E[e²_prior] ≥ σ²_fix`` whatever the prior's actual error, so the window's sum
  is at least χ²ₙ (stochastically) and its lower tail fails at most at its level. With
  ``σ²_fix + σ²_s,prior`` in the denominator instead (before stop 36), a prior better than
  its σ (a conservative process noise) failed it: the Brussels train logs' carrier-fixed
  fixes (σ 3 cm; prior σ_s 0.21 m, the fixes 1 cm from it) were ``degraded`` on 2478 of
  their 2480 epochs, the filter's error against them 0.5-3 cm.
* **Only where sharing could matter.** ``S`` is how far the prior's ``s`` would be off if
  every fix so far had been off by the same multiple ``b = 1`` of its own σ (0 at the start
  and after a recovery). A fix enters with its scalar gain ``K = σ²_s,prior/(σ²_s,prior +
  σ²_fix)``: ``S ← (1 − K) S + K σ_fix``. An epoch is tested only where ``S > σ_s,prior``:
  elsewhere even fixes whose errors all equal the prior's leave the prior within its own σ,
  and no correlation can make it overconfident. With fixes of one σ, ``S → σ_fix`` and the
  test runs where the prior is more precise than the fix (the filter has averaged fixes,
  whose shared error would cost it up to ``σ_fix/σ_s``), not where each fix resets the
  filter (carrier-fixed fixes, K ≈ 0.98: its σ_s is one fix's), nor after a source it
  trusted (a receiver's propagated positions at σ 10 m after carrier-fixed ones).

What stays, by construction: fixes better than their σ *and* averaged by the filter fail
it as shared errors would; no statistic of the along-track fixes alone tells them apart.
Measured (``benchmarks/bench_monitor_honesty.py``, ``results/monitor_honesty.json``):
the three carrier-fixed logs, 2478 of 2480 epochs failing it → 92, all in log_28554's
tunnel, where the receiver's propagated positions (σ 10 m, truly better over its short
stretches: the next carrier-fixed fix finds every one of the 20 stretches' priors within
1σ) are averaged; log_29083, single-point fixes at σ 2.5 m that the filter (σ_s 1.5 m)
follows, failing it on 633 of 875 epochs → 583: across the track, which the filter
cannot follow, they lie 3.5 m RMS from where log_28554's carrier-fixed fixes put the
track, slowly (0.8 m RMS from row to row): errors of their σ's size, shared from epoch to
epoch, the case the test is for (along the track no reference is independent of them);
the urban drive's fix-based filter on white SPP fixes keeps its catches (epochs beyond
3σ_s left ``ok``: 27 → 26 of 315).

``K`` is the gain of the fix alone on ``s``; a filter with other information at the epoch
(range rates, an IMU) weights the fix less, and ``S`` then errs high: more epochs tested.
"""
from __future__ import annotations

import math

import numpy as np

from railnav.navigation.tail_probabilities import chi2_cdf

__all__ = ["SmallDisagreement"]


class SmallDisagreement:
    """The lower-tail test's window of terms and the prior's share ``S`` (module docstring).

    Parameters
    ----------
    window_epochs : int
        `railnav.navigation.monitor_config.MonitorConfig.small_window_epochs`.
    """

    def __init__(self, window_epochs: int) -> None:
        self._terms = np.full(window_epochs, np.nan)     # oldest first, the last `_n`
        self._n = 0
        self._n_finite = 0                                # finite terms of the last `_n`
        self.shared_m = 0.0

    def restart(self) -> None:
        """Forget the window and ``S`` (the filter was re-initialised or widened)."""
        self._n = 0
        self._n_finite = 0
        self.shared_m = 0.0

    def term(self, ds: float, var_fix: float, var_prior: float) -> float:
        """This epoch's term: ``δs²/σ²_fix`` where ``S > σ_s,prior``, else NaN (not
        tested); then the fix's weight enters ``S``.

        Parameters
        ----------
        ds : float
            ``s_fix − s_prior``, m.
        var_fix, var_prior : float
            ``σ²_fix`` (not floored) and ``σ²_s,prior``, m².
        """
        shared = self.shared_m
        if not var_fix > 0.0:
            return math.nan
        self.shared_m = (var_fix * shared + var_prior * math.sqrt(var_fix)) \
            / (var_prior + var_fix)
        return ds * ds / var_fix if shared * shared > var_prior else math.nan

    def push(self, term: float) -> None:
        """Append this epoch's term (NaN: none), the oldest dropped."""
        t = self._terms
        if self._n == t.size and math.isfinite(t[0]):     # the oldest leaves the window
            self._n_finite -= 1
        t[:-1] = t[1:]
        t[-1] = term
        self._n = min(self._n + 1, t.size)
        self._n_finite += math.isfinite(term)

    def tail(self) -> float:
        """Lower χ² tail of the window's terms: ``P(χ²ₙ ≤ Σ)`` over its n finite terms, 1
        without any."""
        if not self._n_finite:                  # (chi2_cdf(0.0, 0): no numbers to sum)
            return 1.0
        terms = self._terms[self._terms.size - self._n:]
        if self._n_finite < self._n:            # every term finite: the window as it is
            terms = terms[np.isfinite(terms)]
        return chi2_cdf(float(np.add.reduce(terms)), int(terms.size))
