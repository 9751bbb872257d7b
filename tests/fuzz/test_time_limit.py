"""The fuzz suite's per-case bound (`tests.support.fuzz.time_limit`): CPU time, not wall."""
from __future__ import annotations

import signal
import time

import pytest

from tests.support.fuzz import FuzzTimeout, time_limit


def _spin(seconds: float) -> None:
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass


def test_a_spinning_case_fails_after_its_cpu_budget():
    start = time.process_time()
    with pytest.raises(FuzzTimeout, match="of CPU"):
        with time_limit(0.2):
            _spin(5.0)
    # the kernel charges ITIMER_PROF by scheduler ticks, process_time() exactly: the timer
    # was seen to fire after 0.178-0.198 s of process_time() under load; the point is that
    # the 5-s spin is cut near its 0.2-s budget, not at it to the millisecond
    assert 0.1 <= time.process_time() - start < 1.0


def test_waiting_is_not_counted_and_the_timer_is_cleared():
    with time_limit(0.2):
        time.sleep(0.4)                     # wall time past the budget, no CPU
        _spin(0.05)
    assert signal.getitimer(signal.ITIMER_PROF) == (0.0, 0.0)
