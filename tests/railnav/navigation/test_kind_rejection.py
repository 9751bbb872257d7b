"""The monitor's whole-kind test (`railnav.navigation.kind_rejection`) against closed forms:
with ``S = σ² I`` the NIS less one common offset is ``Σ (ν_i − ν̄)² / σ²``."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from scipy import stats

from railnav.navigation.kind_rejection import kind_rejected_tail

GATE = 3.73 ** 2            # the screen's default row gate (fault_detection's docstring)


def _epoch(pseudorange, range_rate, sigma=1.0):
    nu = np.concatenate([pseudorange, range_rate]).astype(float)
    keys = [f"G{i:02d}/pseudorange" for i in range(len(pseudorange))] + \
        [f"G{i:02d}/range_rate" for i in range(len(range_rate))]
    return SimpleNamespace(keys=np.array(keys, dtype=object), innov=nu,
                           S=sigma ** 2 * np.eye(nu.size))


def test_every_range_rate_off_by_a_speed_error_is_the_chi2_tail_of_its_spread():
    """Range rates 5-12σ off with different signs (a speed error seen along each line of
    sight), pseudoranges passing: the tail is χ²₅'s of the spread about their mean."""
    rr = np.array([-5.2, 11.9, 5.0, -11.6, -9.5, 6.9])
    tail = kind_rejected_tail(_epoch([0.1, -2.5, -2.5, -1.1, -2.1, -1.9], rr), GATE)
    want = stats.chi2.sf(np.sum((rr - rr.mean()) ** 2), rr.size - 1)
    assert np.isclose(tail, want, rtol=1e-9, atol=0.0)
    assert tail < 1e-6


def test_a_common_offset_of_a_kind_is_a_clock_step_not_a_lost_filter():
    """Every range rate 30σ off by the same amount (a receiver clock-drift step) plus unit
    noise: the residual is χ²₅ of the noise alone, far from ``lost``."""
    noise = np.array([0.3, -1.1, 0.8, 0.2, -0.5, 1.0])
    tail = kind_rejected_tail(_epoch(np.zeros(6), 30.0 + noise), GATE)
    assert np.isclose(tail, stats.chi2.sf(np.sum((noise - noise.mean()) ** 2), 5), rtol=1e-9)
    assert tail > 0.1


def test_no_test_unless_every_row_of_a_kind_fails():
    """One range rate inside the gate (3.7σ), or only three rows of the kind: tail 1."""
    assert kind_rejected_tail(_epoch(np.zeros(6), [-5.2, 11.9, 5.0, -11.6, -50.5, 3.7]),
                              GATE) == 1.0
    assert kind_rejected_tail(_epoch(np.zeros(6), [-20.0, 20.0, 40.0]), GATE) == 1.0
