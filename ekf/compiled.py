"""Compile a step function to C once, cache the shared library on disk, call it by ctypes.

The step function (:func:`ekf.step.build_step`) is written out as C by
``casadi.CodeGenerator``; a small C loop (below) runs it over ``N`` steps, chaining the
state and packed covariance and writing every per-step output into caller-owned buffers.
``gcc -O2 -shared -fPIC`` builds it once (with `INLINE_FLAGS`, and `NATIVE_FLAGS` on
processors with AVX2: the same bits, faster); the library is cached on disk
(`ekf.library_cache`: ``$RAILNAV_CACHE_DIR/ekf`` or the user cache directory, atomic
writes, one compiling process at a time) under a name that is the SHA-256 of the CasADi
function's serialization, the C template, the compiler command and the CasADi version, so
later processes (runs, tests, Monte Carlo workers) load it without generating code or
compiling. A run of ``N`` steps is one ctypes call on NumPy buffers: no ``casadi.DM``
conversion and no per-step Python.

Compared with CasADi's own ``jit`` option on a ``mapaccum``: the same generated code,
but ``N`` is a run-time argument (one library for any interval length) and the library
survives the process.
"""
from __future__ import annotations

import ctypes
import functools
import hashlib
import logging
import os
import platform
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import casadi as ca
import numpy as np

from ekf.errors import FilterError
from ekf.library_cache import default_cache_dir, load_library

__all__ = ["CompileOptions", "CompiledLoop", "CompiledRows", "compiler_available",
           "NATIVE_FLAGS", "INLINE_FLAGS", "has_avx2", "build_library", "load_template",
           "address", "compile_source"]

log = logging.getLogger(__name__)

#: Flags for processors with AVX2, without changing any result: ``-mavx2`` (VEX-encoded
#: code: the constrained filter's step loop is ~1.5x faster, mostly because the code no
#: longer switches between SSE and libm's AVX sin/cos) and ``-ffp-contract=off``. FMA stays
#: off (``-mavx2`` does not enable it): a fused multiply-add rounds once instead of twice,
#: other bits. ``-march=native`` is NOT bit-safe: on AVX-512 machines GCC forms
#: ``vfmaddsub`` in vectorized code even with ``-ffp-contract=off`` (found on the
#: unconstrained filter's range-rate rows). Tested: outputs equal to the bit to ``-O2``
#: alone (`tests/ekf/test_compiled.py`). A compiler refusing them gets a retry without.
NATIVE_FLAGS = ("-mavx2", "-ffp-contract=off")

#: Flags for any processor, without changing any result: ``-fno-semantic-interposition``
#: lets GCC inline and call directly, inside the library, the functions that CasADi's code
#: exports (``casadi_sq``, the step function called by the loop) instead of going through
#: the PLT as ``-fPIC`` otherwise requires (a library's symbols could be replaced at load
#: time). The paper2017 trip's step loop: ~6 % less CPU (0.195 → 0.183 s, best of 7,
#: load ~5), outputs equal to the bit. A compiler refusing them gets a retry without
#: (with `NATIVE_FLAGS`).
INLINE_FLAGS = ("-fno-semantic-interposition",)


def has_avx2() -> bool:
    """Whether this is an x86-64 processor with AVX2 (Linux ``/proc/cpuinfo``; False when
    it cannot be told)."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("flags"):
                    return "avx2" in line.split()
    except OSError:
        pass
    return False

_LOOP_TEMPLATE = r"""
/* ---- ekf/compiled.py: run {fname} over N steps, chaining inputs 0,1 from outputs 0,1 ---- */
CASADI_SYMBOL_EXPORT int {loop}(long long N, const casadi_real* x0, const casadi_real* P0,
                                const casadi_real* d, casadi_real** out,
                                casadi_int* iw, casadi_real* w) {{
  const casadi_real* arg[{sz_arg}];
  casadi_real* res[{sz_res}];
  long long k;
  int i;
  static const long long size_out[{n_out}] = {{{sizes_out}}};
  for (k = 0; k < N; ++k) {{
    arg[0] = k == 0 ? x0 : out[0] + (k - 1) * size_out[0];
    arg[1] = k == 0 ? P0 : out[1] + (k - 1) * size_out[1];
    arg[2] = d + k * {size_d};
    for (i = 0; i < {n_out}; ++i) res[i] = out[i] + k * size_out[i];
    if ({fname}(arg, res, iw, w, 0)) return 1;
  }}
  return 0;
}}
"""

_ROWS_TEMPLATE = r"""
/* ---- ekf/compiled.py: evaluate {fname} for m rows, x shared, row parameters advancing ---- */
CASADI_SYMBOL_EXPORT int {loop}(long long m, const casadi_real* x, const casadi_real* p,
                                casadi_real* z, casadi_real* H,
                                casadi_int* iw, casadi_real* w) {{
  const casadi_real* arg[{sz_arg}];
  casadi_real* res[{sz_res}];
  long long j;
  for (j = 0; j < m; ++j) {{
    arg[0] = x;
    arg[1] = p + j * {size_p};
    res[0] = z + j * {size_z};
    res[1] = H + j * {size_h};
    if ({fname}(arg, res, iw, w, 0)) return 1;
  }}
  return 0;
}}
"""


@dataclass(frozen=True)
class CompileOptions:
    """How generated C is compiled.

    Attributes
    ----------
    compiler : str
        C compiler command (must accept gcc-style flags).
    flags : tuple of str
        Optimization flags (default ``-O2`` and `INLINE_FLAGS`, and `NATIVE_FLAGS` on
        processors with AVX2: the flags are in the cache key, so a cache shared with other
        processors is safe).
    cache_dir : str or None
        Where libraries are cached; ``None``: ``$RAILNAV_CACHE_DIR/ekf``, else the user
        cache directory's ``railnav/ekf`` (`ekf.library_cache`).
    """

    compiler: str = "gcc"
    flags: tuple[str, ...] = ("-O2", *INLINE_FLAGS, *NATIVE_FLAGS) if has_avx2() \
        else ("-O2", *INLINE_FLAGS)
    cache_dir: str | None = None

    def directory(self) -> Path:
        """The cache directory (read when a library is loaded; created when one is built)."""
        return Path(self.cache_dir) if self.cache_dir is not None else default_cache_dir()

    def command(self) -> list[str]:
        """The compiler command without its input and output files."""
        return [self.compiler, *self.flags, "-shared", "-fPIC"]


def compiler_available(opts: CompileOptions = CompileOptions()) -> bool:
    """Whether the configured C compiler is on ``PATH``."""
    return shutil.which(opts.compiler) is not None


def _c_source(fun: ca.Function, template: str, loop: str) -> str:
    with tempfile.TemporaryDirectory() as tmp:
        cg = ca.CodeGenerator(f"{fun.name()}.c", {"with_header": False, "verbose": False})
        cg.add(fun)
        path = Path(cg.generate(tmp + os.sep))
        source = path.read_text()
    sizes_out = ", ".join(str(fun.nnz_out(i)) for i in range(fun.n_out()))
    return source + template.format(
        fname=fun.name(), loop=loop, sz_arg=max(fun.sz_arg(), 1), sz_res=max(fun.sz_res(), 1),
        n_out=fun.n_out(), sizes_out=sizes_out, size_d=fun.nnz_in(fun.n_in() - 1),
        size_a=fun.nnz_in(0),
        size_p=fun.nnz_in(fun.n_in() - 1), size_z=fun.nnz_out(0),
        size_h=fun.nnz_out(fun.n_out() - 1))


def load_template(fun: ca.Function, template: str, opts: CompileOptions
                  ) -> tuple[ctypes.CDLL, ctypes._CFuncPtr, float]:
    """`fun`'s C with the loop of `template` (this module's loop templates, or
    `ekf.compiled_each`'s), built or read from the cache (`build_library`): the library,
    its ``<name>_loop`` entry and the compile time (s, 0 from the cache)."""
    loop = f"{fun.name()}_loop"
    return build_library(fun, (template,), loop, lambda: _c_source(fun, template, loop),
                         opts)


def build_library(fun: ca.Function, templates: tuple[str, ...], entry: str,
                  source: Callable[[], str], opts: CompileOptions
                  ) -> tuple[ctypes.CDLL, ctypes._CFuncPtr, float]:
    """The cached library of C written for `fun` (compiled on a cache miss) and its
    function `entry` (returning ``int``).

    Parameters
    ----------
    fun : casadi.Function
    templates : tuple of str
        Everything besides `fun` that the C is written from (templates, a version of the
        writer): part of the cache key.
    entry : str
        The exported C function.
    source : callable
        ``source()`` writes the C (called only on a cache miss).
    opts : CompileOptions

    Returns
    -------
    library, entry function, compile seconds (0 when cached)
    """
    command = opts.command()
    key = _cache_key(fun, templates, entry, tuple(command))
    lib, seconds = load_library(opts.directory(), key,
                                lambda path: compile_source(source(), command, path))
    function = getattr(lib, entry)
    function.restype = ctypes.c_int
    return lib, function, seconds


@functools.lru_cache(maxsize=64)
def _cache_key(fun: ca.Function, templates: tuple[str, ...], entry: str,
               command: tuple[str, ...]) -> str:
    """What a library is, hashed without generating its code: the function (CasADi's
    serialization, stable across processes), the C templates and entry name, the compiler
    command and the CasADi version (whose code generator writes the C). Kept per function
    object (a CasADi function is immutable; its serialization costs ~6-12 ms for a
    filter's step: `ekf.step.build_step` returns the same object for the same model)."""
    digest = hashlib.sha256()
    for part in (ca.__version__, *templates, entry, " ".join(command), fun.serialize()):
        digest.update(part.encode())
        digest.update(b"\0")
    return digest.hexdigest()[:24]


def compile_source(source: str, command: list[str], target: Path, *,
                   name: str = "step") -> None:
    """Compile a C source (written as ``name.c``) into the shared library `target`
    (without `INLINE_FLAGS` and `NATIVE_FLAGS` if the compiler refuses them); `FilterError`
    when it fails."""
    with tempfile.TemporaryDirectory() as tmp:
        c_file = Path(tmp) / f"{name}.c"
        c_file.write_text(source)
        result = subprocess.run([*command, str(c_file), "-o", str(target), "-lm"],
                                capture_output=True, text=True, check=False)
        optional = (*INLINE_FLAGS, *NATIVE_FLAGS)
        portable = [flag for flag in command if flag not in optional]
        if result.returncode != 0 and portable != command:
            log.info("compiling with %s failed; compiling without", " ".join(optional))
            result = subprocess.run([*portable, str(c_file), "-o", str(target), "-lm"],
                                    capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise FilterError(f"compiling {name}.c failed: {result.stderr[-2000:]}")


def address(array: np.ndarray) -> int:
    """The data pointer of a C-contiguous array: ``array.ctypes.data`` (~4 µs a call, a
    new ``_ctypes`` object each time) through a ctypes view of its buffer (~1.4 µs), for a
    read-only array the ``ctypes`` attribute. The caller keeps `array` alive during the
    call it passes the pointer to."""
    try:
        return ctypes.addressof(ctypes.c_char.from_buffer(array))
    except (TypeError, ValueError, BufferError):        # read-only, or not exportable
        return array.ctypes.data



class CompiledLoop:
    """A step function compiled to a C loop over ``N`` steps.

    Parameters
    ----------
    fun : casadi.Function
        ``(x, P, d) -> outputs`` with outputs 0 and 1 the next ``x`` and ``P`` (as made by
        :func:`ekf.step.build_step`); all inputs/outputs dense vectors.
    opts : CompileOptions

    Attributes
    ----------
    compile_seconds : float
        Wall time spent compiling in this process (0 when the library was cached).
    """

    def __init__(self, fun: ca.Function, opts: CompileOptions = CompileOptions()) -> None:
        self.n_out = fun.n_out()
        self.sizes_out = tuple(fun.nnz_out(i) for i in range(self.n_out))
        self.sizes_in = tuple(fun.nnz_in(i) for i in range(fun.n_in()))
        self._lib, self._fun, self.compile_seconds = load_template(fun, _LOOP_TEMPLATE, opts)
        self._fun.argtypes = [ctypes.c_longlong] + [ctypes.c_void_p] * 6
        self._iw = np.zeros(max(fun.sz_iw(), 1), dtype=np.int64)
        self._w = np.zeros(max(fun.sz_w(), 1))
        self._ptrs = (ctypes.c_void_p * self.n_out)()
        #: The addresses of the buffers every call passes (held by this object).
        self._fixed = (ctypes.addressof(self._ptrs), address(self._iw), address(self._w))

    def run(self, x0: np.ndarray, P0: np.ndarray, d: np.ndarray) -> list[np.ndarray]:
        """Run ``N = len(d)`` steps.

        Parameters
        ----------
        x0 : ndarray, shape (n,)
        P0 : ndarray, shape (n(n+1)/2,)
        d : ndarray, shape (N, k_d)

        Returns
        -------
        list of ndarray
            One ``(N, size_i)`` array per output of the step function.
        """
        x0 = np.ascontiguousarray(x0, dtype=float)
        P0 = np.ascontiguousarray(P0, dtype=float)
        d = np.ascontiguousarray(d, dtype=float)
        N = d.shape[0]
        if x0.shape != (self.sizes_in[0],) or P0.shape != (self.sizes_in[1],) \
                or d.shape[1:] != (self.sizes_in[2],):
            raise FilterError(f"compiled step expects x {self.sizes_in[0]}, P "
                              f"{self.sizes_in[1]}, d (N, {self.sizes_in[2]}); got "
                              f"{x0.shape}, {P0.shape}, {d.shape}")
        outs = [np.empty((N, size)) for size in self.sizes_out]
        for i, out in enumerate(outs):
            self._ptrs[i] = address(out)
        status = self._fun(N, address(x0), address(P0), address(d), *self._fixed)
        if status:
            raise FilterError("the compiled step function reported an error")
        return outs


class CompiledRows:
    """A measurement-row function ``(x, p_row) -> (z_row, H_row)`` compiled to a C loop
    over ``m`` rows (``x`` shared).

    Parameters
    ----------
    fun : casadi.Function
        Two dense vector inputs ``x (n)``, ``p (n_p)``; two outputs ``z (k)`` and the
        Jacobian row block ``H`` as ``k * n`` numbers, row by row.
    opts : CompileOptions
    """

    def __init__(self, fun: ca.Function, opts: CompileOptions = CompileOptions()) -> None:
        self.n = fun.nnz_in(0)
        self.n_p = fun.nnz_in(1)
        self.k = fun.nnz_out(0)
        self._lib, self._fun, self.compile_seconds = load_template(fun, _ROWS_TEMPLATE, opts)
        self._fun.argtypes = [ctypes.c_longlong] + [ctypes.c_void_p] * 6
        self._iw = np.zeros(max(fun.sz_iw(), 1), dtype=np.int64)
        self._w = np.zeros(max(fun.sz_w(), 1))
        #: The addresses of the work buffers every call passes (held by this object).
        self._fixed = (address(self._iw), address(self._w))

    def run(self, x: np.ndarray, p_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``z (m * k,)`` and ``H (m * k, n)`` for ``x (n,)`` and ``p_rows (m, n_p)``."""
        x = np.ascontiguousarray(x, dtype=float)
        p_rows = np.ascontiguousarray(p_rows, dtype=float)
        m = p_rows.shape[0]
        z = np.empty(m * self.k)
        H = np.empty((m * self.k, self.n))
        if self._fun(m, address(x), address(p_rows), address(z), address(H), *self._fixed):
            raise FilterError("the compiled measurement function reported an error")
        return z, H
