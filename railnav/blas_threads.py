"""One BLAS thread for the command line's process, unless the user chose otherwise.

NumPy and SciPy each load their own OpenBLAS, and each OpenBLAS starts a pool of worker
threads, one per core, when it is loaded; the new threads spin while they wait for work.
No ``railnav`` command gives OpenBLAS work large enough to share: the filters' matrices
are 7×7 to 20×20, and the batched arithmetic over samples is NumPy's own (elementwise,
``matmul`` of stacked 3×3), not BLAS's threads. Starting the pools cost 0.035 s of CPU
for NumPy's OpenBLAS and 0.07 s for SciPy's on the 2-core machine of issue 15 (importing
NumPy then ``scipy.linalg``: 0.15 s of CPU with one thread, 0.25 s with the default),
about 0.1 s of each ``railnav run`` (6-7 % of ``railnav run paper2017.csv --no-plots``,
its outputs the same bytes).

`one_blas_thread` sets ``OPENBLAS_NUM_THREADS=1`` before NumPy is imported
(`railnav.cli` calls it first): OpenBLAS reads it when it is loaded. A user who set
``OPENBLAS_NUM_THREADS``, ``GOTO_NUM_THREADS`` or ``OMP_NUM_THREADS`` (which OpenBLAS
reads in that order) keeps that choice, and a process that imported NumPy already (a
program that imports `railnav.cli`) is left as it is.
"""
from __future__ import annotations

import os
import sys

__all__ = ["one_blas_thread", "THREAD_VARIABLES"]

#: The variables OpenBLAS reads for its number of threads, in its order.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def one_blas_thread() -> bool:
    """Set ``OPENBLAS_NUM_THREADS=1`` where it takes effect and the user chose nothing
    (module docstring); returns whether it was set."""
    if "numpy" in sys.modules or any(os.environ.get(v) for v in THREAD_VARIABLES):
        return False
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    return True
