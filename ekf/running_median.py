"""The median of each of a sequence of windows of samples: a small C kernel, a NumPy twin.

`window_rows(u, lo, hi)` gives, for each row ``k``, the per-column median of the samples
``u[lo[k]:hi[k]]`` (the mean of the two middle values of an even count, computed as
``0.5 * (a + b)``, as `ekf.step.window_median` has always computed it). A median is an
order statistic: any exact method gives the same bits, so

* the compiled kernel keeps each column's window as a sorted array and moves it from one
  window to the next by deleting the samples that leave and inserting those that enter
  (a count of the values below, which vectorizes, and one shift of the values in
  between: ``O(L)`` per sample for windows of ``L`` samples, in any order of the
  windows, overlapping or not);
* the NumPy twin (no C compiler, or ``compiled=False``) sorts a padded ``(M, L, n_u)``
  table of the windows (``+inf`` past each window's end) along the window.

The two are tested against each other and against `numpy.median`
(``tests/ekf/test_running_median.py``). Signed zeros compare equal in both (a sort may
leave them in either order): a median of zeros can differ in its sign only.

The kernel is compiled at first use with the engine's compiler
(`ekf.compiled.CompileOptions`'s flags and ``-O3``: the kernel only compares and
copies, and its one mean is not contracted) and cached on disk like the step functions
(`ekf.library_cache`: later processes load it without compiling).
"""
from __future__ import annotations

import ctypes
import functools
import hashlib
import logging

import numpy as np
import numpy.typing as npt

from ekf.compiled import CompileOptions, compile_source, compiler_available
from ekf.errors import FilterError, ModelError
from ekf.library_cache import load_library

__all__ = ["window_rows", "compiled_kernel"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

_SOURCE = r"""
/* ekf/running_median.py: medians of windows [lo[k], hi[k]) of the rows of u (m x n_u). */
#include <string.h>

/* how many values of the sorted buf are below v: where v goes, or where it is (a count,
   not a binary search: it vectorizes) */
static long long below(const double* buf, long long n, double v) {
  long long j, c = 0;
  for (j = 0; j < n; ++j) c += buf[j] < v;
  return c;
}

static void insert(double* buf, long long* n, double v) {
  long long p = below(buf, *n, v);
  memmove(buf + p + 1, buf + p, (size_t)(*n - p) * sizeof *buf);
  buf[p] = v;
  ++*n;
}

static void erase(double* buf, long long* n, double v) {
  long long i = below(buf, *n, v);             /* buf[i] == v: it is in the window */
  memmove(buf + i, buf + i + 1, (size_t)(*n - i - 1) * sizeof *buf);
  --*n;
}

/* erase v_out and insert v_in with one shift of the values between them (where each
   goes: both counts in one pass over the window) */
static void replace(double* buf, long long n, double v_out, double v_in) {
  long long i = 0, p = 0, j;
  for (j = 0; j < n; ++j) {
    i += buf[j] < v_out;
    p += buf[j] < v_in;
  }
  if (p > i) {
    for (j = i; j < p - 1; ++j) buf[j] = buf[j + 1];
    buf[p - 1] = v_in;
  } else {
    for (j = i; j > p; --j) buf[j] = buf[j - 1];
    buf[p] = v_in;
  }
}

/* the indices of [a0, b0) then [a1, b1), one by one */
typedef struct { long long a0, b0, a1, b1; } spans;

static int next_index(spans* s, long long* j) {
  if (s->a0 < s->b0) { *j = s->a0++; return 1; }
  if (s->a1 < s->b1) { *j = s->a1++; return 1; }
  return 0;
}

static long long min_ll(long long a, long long b) { return a < b ? a : b; }
static long long max_ll(long long a, long long b) { return a > b ? a : b; }

int window_medians(long long m, long long n_u, const double* u, const long long* lo,
                   const long long* hi, double* out, double* buf) {
  long long c, k, j_out, j_in;
  for (c = 0; c < n_u; ++c) {
    long long n = 0, lo0 = 0, hi0 = 0;
    for (k = 0; k < m; ++k) {
      long long lo1 = lo[k], hi1 = hi[k];
      if (hi1 <= lo1) return 1;
      /* the samples that leave the window, and those that enter it */
      spans leave = {lo0, min_ll(hi0, lo1), max_ll(lo0, hi1), hi0};
      spans enter = {lo1, min_ll(hi1, lo0), max_ll(lo1, hi0), hi1};
      int more_out = next_index(&leave, &j_out), more_in = next_index(&enter, &j_in);
      while (more_out && more_in) {
        replace(buf, n, u[j_out * n_u + c], u[j_in * n_u + c]);
        more_out = next_index(&leave, &j_out);
        more_in = next_index(&enter, &j_in);
      }
      while (more_out) {
        erase(buf, &n, u[j_out * n_u + c]);
        more_out = next_index(&leave, &j_out);
      }
      while (more_in) {
        insert(buf, &n, u[j_in * n_u + c]);
        more_in = next_index(&enter, &j_in);
      }
      out[k * n_u + c] = 0.5 * (buf[(n - 1) / 2] + buf[n / 2]);
      lo0 = lo1;
      hi0 = hi1;
    }
  }
  return 0;
}
"""


def window_rows(u: Array, lo: npt.NDArray[np.integer], hi: npt.NDArray[np.integer], *,
                compiled: bool | None = None) -> Array:
    """Per-column medians of the windows ``u[lo[k]:hi[k]]`` (module docstring).

    Parameters
    ----------
    u : ndarray, shape (N, n_u)
        Samples (finite).
    lo, hi : ndarray of int, shape (M,)
        Each window's first sample and one past its last, ``0 <= lo < hi <= N``.
    compiled : bool, optional
        True: the C kernel (`ModelError` without a compiler); False: the NumPy twin;
        None (default): the kernel where a compiler is available.

    Returns
    -------
    ndarray, shape (M, n_u)
    """
    u = np.ascontiguousarray(u, dtype=float)
    lo = np.ascontiguousarray(lo, dtype=np.int64)
    hi = np.ascontiguousarray(hi, dtype=np.int64)
    if u.ndim != 2 or lo.shape != hi.shape or lo.ndim != 1:
        raise ModelError(f"window_rows needs u (N, n_u), lo and hi (M,); got {u.shape}, "
                         f"{lo.shape}, {hi.shape}")
    if lo.size and (lo.min() < 0 or hi.max() > u.shape[0] or (hi <= lo).any()):
        raise ModelError("window_rows needs 0 <= lo < hi <= N for every window")
    kernel = compiled_kernel() if compiled is not False else None
    if compiled and kernel is None:
        raise ModelError("the running-median kernel needs a C compiler")
    if kernel is None or lo.size == 0:
        return _numpy_rows(u, lo, hi)
    out = np.empty((lo.size, u.shape[1]))
    buf = np.empty(max(int((hi - lo).max()), 1))
    if kernel(lo.size, u.shape[1], u.ctypes.data, lo.ctypes.data, hi.ctypes.data,
              out.ctypes.data, buf.ctypes.data):
        raise ModelError("window_rows: an empty window")      # checked above: a bug
    return out


def _numpy_rows(u: Array, lo: npt.NDArray[np.int64], hi: npt.NDArray[np.int64]) -> Array:
    """`window_rows` in NumPy: a padded ``(M, L, n_u)`` table sorted along the window."""
    if lo.size == 0:
        return np.zeros((0, u.shape[1]))
    count = hi - lo
    index = lo[:, None] + np.arange(int(count.max()))
    valid = index < hi[:, None]
    table = u[np.minimum(index, u.shape[0] - 1)]                   # (M, L, n_u)
    table[~valid] = np.inf
    table.sort(axis=1)
    rows = np.arange(lo.size)
    return 0.5 * (table[rows, (count - 1) // 2] + table[rows, count // 2])


@functools.lru_cache(maxsize=1)
def compiled_kernel():
    """The C kernel's entry point (a ctypes function), built and cached on disk at first
    use; None without a C compiler or when compiling fails (one warning; `window_rows`
    then uses its NumPy twin)."""
    opts = CompileOptions()
    if not compiler_available(opts):
        return None
    command = [*opts.command(), "-O3"]
    key = hashlib.sha256("\0".join([_SOURCE, " ".join(command)]).encode()).hexdigest()[:24]
    try:
        lib, _ = load_library(opts.directory(), f"median_{key}", lambda path: compile_source(
            _SOURCE, command, path, name="running_median"))
    except (OSError, FilterError) as exc:
        log.warning("the running-median kernel did not compile (%s): using NumPy", exc)
        return None
    entry = lib.window_medians
    entry.restype = ctypes.c_int
    entry.argtypes = [ctypes.c_longlong, ctypes.c_longlong] + [ctypes.c_void_p] * 5
    return entry

