"""One BLAS thread for the command line's process, unless the user chose otherwise.

NumPy and SciPy each load their own OpenBLAS, and each OpenBLAS starts a pool of worker
threads, one per core, when it is loaded; the new threads spin on the other cores while
the imports go on. The commands' BLAS work is small: the filters' matrices are 7×7 to
20×20, and the batched arithmetic over samples is NumPy's own (elementwise, ``matmul`` of
stacked 3×3), not BLAS's threads; ``railnav track fit`` (the largest least-squares
problems) was measured alike: the same bytes, no slower. On the 2-core machine of issue
15 the pools cost the imports of ``railnav run paper2017.csv`` 0.24 s of CPU (0.58 s
against 0.34 s, best of 5 fresh processes): the whole command 5-9 % of its CPU, and of
its wall time where the other core is busy (3-7 % at a load average of 2-3), little where
it is idle. The outputs are the same bytes (``run``, ``reproduce paper2017`` and
``track fit`` compared).

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
