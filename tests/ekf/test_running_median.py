"""`ekf.running_median.window_rows`: the compiled kernel and the NumPy twin against
`numpy.median` of each window taken in a plain loop, on the windows of
`ekf.step.window_median` (jittered times, a gap, windows shrunk at the ends: odd and even
counts) and on arbitrary windows (jumping back and forth, disjoint, repeated values)."""
from __future__ import annotations

import numpy as np
import pytest

from ekf.compiled import compiler_available
from ekf.errors import ModelError
from ekf.running_median import window_rows
from ekf.step import WINDOW_TOL_S, window_median, window_median_at

needs_compiler = pytest.mark.skipif(not compiler_available(), reason="no C compiler")
BACKENDS = [pytest.param(True, marks=needs_compiler), False]


def _loop(u, lo, hi):
    """Each window's median the slow way (`numpy.median`: the mean of the two middle
    values of an even count)."""
    return np.array([np.median(u[a:b], axis=0) for a, b in zip(lo, hi)])


def _jittered(rng, n=600):
    t = np.cumsum(rng.uniform(0.004, 0.016, n))
    t[300:] += 0.3                                        # a gap
    return np.sort(np.concatenate([t, [t[150] + 1e-4]]))  # an inserted sample


@pytest.mark.parametrize("compiled", BACKENDS)
@pytest.mark.parametrize("window_s", [0.0, 0.03, 0.05, 0.5, 10.0])
def test_window_median_windows_equal_numpy_median(rng, compiled, window_s):
    """The windows of `window_median` (centred, shrunk to the samples there are at both
    ends; 10 s: every window reaches an end)."""
    t = _jittered(rng)
    u = rng.normal(size=(t.size, 6))
    half = np.minimum(0.5 * window_s, np.minimum(t - t[0], t[-1] - t)) + WINDOW_TOL_S
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right")
    assert set(np.unique((hi - lo) % 2)) == ({1} if window_s < 0.01 else {0, 1})
    assert np.array_equal(window_rows(u, lo, hi, compiled=compiled), _loop(u, lo, hi))


@pytest.mark.parametrize("compiled", BACKENDS)
def test_arbitrary_windows_equal_numpy_median(rng, compiled):
    """Windows in random order (back and forth, overlapping or disjoint, of 1 to 80
    samples) over values with many repeats (rounded to 0.25)."""
    u = np.round(rng.normal(size=(500, 3)) * 4.0) / 4.0
    lo = rng.integers(0, 499, 400)
    hi = np.minimum(lo + rng.integers(1, 81, 400), 500)
    assert np.array_equal(window_rows(u, lo, hi, compiled=compiled), _loop(u, lo, hi))


@needs_compiler
def test_kernel_equals_numpy_twin_on_a_long_series(rng):
    """100 000 jittered samples at 100 Hz, the 0.5-s window of the constrained filter:
    the two implementations to the bit."""
    t = np.cumsum(rng.uniform(0.009, 0.011, 100_000))
    u = rng.normal(size=(t.size, 6))
    half = np.minimum(0.25, np.minimum(t - t[0], t[-1] - t)) + WINDOW_TOL_S
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right")
    assert np.array_equal(window_rows(u, lo, hi, compiled=True),
                          window_rows(u, lo, hi, compiled=False))


@pytest.mark.parametrize("start, stop", [(0, 30), (100, 250), (570, 601)])
def test_window_median_at_is_the_whole_series_rows(rng, start, stop):
    """Rows of a chunk from the samples within reach equal the whole series' rows."""
    t = _jittered(rng)
    u = rng.normal(size=(t.size, 6))
    assert np.array_equal(window_median_at(t, u, start, stop, 0.5),
                          window_median(t, u, 0.5)[start:stop])


def test_signed_zeros_are_equal_numbers():
    """Zeros of both signs: the median is a zero (its sign may differ from a sort's)."""
    u = np.array([[0.0], [-0.0], [0.0], [-0.0], [1.0]])
    got = window_rows(u, np.array([0, 0, 1]), np.array([4, 3, 5]))
    assert np.array_equal(got, np.zeros((3, 1)))


def test_bad_windows_are_refused():
    u = np.zeros((5, 2))
    with pytest.raises(ModelError):
        window_rows(u, np.array([2]), np.array([2]))       # empty
    with pytest.raises(ModelError):
        window_rows(u, np.array([0]), np.array([6]))       # past the end
    with pytest.raises(ModelError):
        window_rows(u[:, 0], np.array([0]), np.array([1]))  # not (N, n_u)
