"""One BLAS thread for the fitter's small dense products.

The fits multiply and solve matrices of a few thousand by a few tens. OpenBLAS spreads such
products over all cores; on a machine busy with other work the threads wait on each other
and the products were measured 30 to 300 times slower than on one thread (``JᵀJ`` of a
2200 × 150 Jacobian: 0.11 s against 0.004 s). `single_blas_thread` sets the number of
threads of the calling thread only (``openblas_set_num_threads_local``, OpenBLAS ≥ 0.3.27,
as bundled with NumPy and SciPy wheels) for the duration of a block, and restores it.
Where no such library is loaded (another BLAS) it does nothing.
"""
from __future__ import annotations

import ctypes
import glob
import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager
from functools import lru_cache

log = logging.getLogger(__name__)

__all__ = ["single_blas_thread"]

#: Where the NumPy and SciPy wheels keep their bundled OpenBLAS, relative to the package.
BUNDLED_LIBRARY_DIRS = ("numpy.libs", "scipy.libs")
LIBRARY_PATTERN = "lib*openblas*.so*"


@lru_cache(maxsize=1)
def _libraries() -> tuple[ctypes.CDLL, ...]:
    import numpy
    site = os.path.dirname(os.path.dirname(numpy.__file__))
    found = []
    for folder in BUNDLED_LIBRARY_DIRS:
        for path in sorted(glob.glob(os.path.join(site, folder, LIBRARY_PATTERN))):
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            if hasattr(lib, "openblas_set_num_threads_local"):
                lib.openblas_set_num_threads_local.argtypes = [ctypes.c_int]
                lib.openblas_set_num_threads_local.restype = ctypes.c_int
                found.append(lib)
    log.debug("OpenBLAS libraries with thread-local control: %d", len(found))
    return tuple(found)


@contextmanager
def single_blas_thread() -> Iterator[None]:
    """Run the block with one BLAS thread in the calling thread."""
    libs = _libraries()
    previous = [lib.openblas_set_num_threads_local(1) for lib in libs]
    try:
        yield
    finally:
        for lib, n in zip(libs, previous):
            lib.openblas_set_num_threads_local(n)
