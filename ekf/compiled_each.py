"""A function of two vectors compiled for every pair of their rows (`CompiledEach`).

For functions ``(a, p) -> outputs`` evaluated at K rows ``a`` (e.g. receiver guesses)
against m rows ``p`` (e.g. an epoch's satellites): the C written by
``casadi.CodeGenerator`` with a double loop (below), compiled and cached on disk as
`ekf.compiled`'s step loops are (same cache, key, flags), one ctypes call for all pairs,
each output written to its own contiguous part of one buffer.
"""
from __future__ import annotations

import ctypes

import casadi as ca
import numpy as np

from ekf.compiled import CompileOptions, address, load_template
from ekf.errors import FilterError

__all__ = ["CompiledEach"]

_EACH_TEMPLATE = r"""
/* ---- ekf/compiled_each.py: {fname} for every pair (input 0 row k, input 1 row j) ---- */
CASADI_SYMBOL_EXPORT int {loop}(long long K, long long m, const casadi_real* a,
                                const casadi_real* p, casadi_real** out,
                                casadi_int* iw, casadi_real* w) {{
  const casadi_real* arg[{sz_arg}];
  casadi_real* res[{sz_res}];
  long long k, j;
  int i;
  static const long long size_out[{n_out}] = {{{sizes_out}}};
  for (k = 0; k < K; ++k) {{
    for (j = 0; j < m; ++j) {{
      arg[0] = a + k * {size_a};
      arg[1] = p + j * {size_p};
      for (i = 0; i < {n_out}; ++i) res[i] = out[i] + (k * m + j) * size_out[i];
      if ({fname}(arg, res, iw, w, 0)) return 1;
    }}
  }}
  return 0;
}}
"""


class CompiledEach:
    """A function ``(a, p) -> outputs`` (dense vectors) compiled to a C loop over every
    pair of ``K`` rows ``a`` and ``m`` rows ``p``: one ctypes call for all pairs.

    Parameters
    ----------
    fun : casadi.Function
        Two dense vector inputs ``a (n_a)``, ``p (n_p)``; dense outputs.
    opts : CompileOptions
    """

    def __init__(self, fun: ca.Function, opts: CompileOptions = CompileOptions()) -> None:
        self.n_a, self.n_p = fun.nnz_in(0), fun.nnz_in(1)
        self.sizes_out = tuple(fun.nnz_out(i) for i in range(fun.n_out()))
        self._lib, self._fun, self.compile_seconds = load_template(fun, _EACH_TEMPLATE, opts)
        self._fun.argtypes = [ctypes.c_longlong] * 2 + [ctypes.c_void_p] * 5
        self._iw = np.zeros(max(fun.sz_iw(), 1), dtype=np.int64)
        self._w = np.zeros(max(fun.sz_w(), 1))
        self._ptrs = (ctypes.c_void_p * len(self.sizes_out))()
        #: The addresses of the buffers every call passes (held by this object).
        self._fixed = (ctypes.addressof(self._ptrs), address(self._iw), address(self._w))
        self._total = sum(self.sizes_out)
        self._starts = np.cumsum((0,) + self.sizes_out[:-1]).tolist()

    def run(self, a_rows: np.ndarray, p_rows: np.ndarray) -> list[np.ndarray]:
        """Each output for C-contiguous float ``a_rows (K, n_a)`` and ``p_rows (m, n_p)``:
        ``(K, m)`` for an output of one number, ``(K, m, size)`` for a longer one."""
        if a_rows.ndim != 2 or a_rows.shape[1] != self.n_a or p_rows.ndim != 2 \
                or p_rows.shape[1] != self.n_p:
            raise FilterError(f"compiled function expects rows (K, {self.n_a}) and "
                              f"(m, {self.n_p}); got {a_rows.shape}, {p_rows.shape}")
        a_rows = np.ascontiguousarray(a_rows, dtype=float)
        p_rows = np.ascontiguousarray(p_rows, dtype=float)
        K, m = a_rows.shape[0], p_rows.shape[0]
        # one buffer, each output a contiguous part of it (one allocation, one address)
        buffer = np.empty(K * m * self._total)
        base, ptrs, outs = address(buffer) if buffer.size else 0, self._ptrs, []
        for i, (size, start) in enumerate(zip(self.sizes_out, self._starts)):
            part = buffer[start * K * m:(start + size) * K * m]
            outs.append(part.reshape((K, m) if size == 1 else (K, m, size)))
            ptrs[i] = base + 8 * start * K * m
        if self._fun(K, m, address(a_rows), address(p_rows), *self._fixed):
            raise FilterError("the compiled function reported an error")
        return outs
