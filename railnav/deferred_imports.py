"""NumPy's developer tools loaded when first used, not when SciPy starts (start-up time).

SciPy's array-API layer (``scipy._lib.array_api_compat.numpy``, imported by every SciPy
submodule the engine uses: ``scipy.linalg``, ``scipy.special``) copies NumPy's namespace by
reading each public attribute, and NumPy imports its public submodules on first attribute
access: ``numpy.f2py`` (the Fortran wrapper generator, whose ``crackfortran`` compiles some
60 regular expressions) and ``numpy.testing`` (with ``unittest``) are loaded although no
run uses them: ~0.1 s of every ``railnav`` command's start in ``python -X importtime``,
0.05-0.1 s of CPU measured (a whole ``railnav run`` of paper2017: 4 % less CPU).

`defer_numpy_tools` makes those two modules lazy (`importlib.util.LazyLoader`, the
standard library's deferred import): importing them gives the module object at once and
runs its code at the first attribute access, so a program that uses them sees no
difference. The command line installs it (`railnav.cli`) before anything imports SciPy.
"""
from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import sys

__all__ = ["defer_numpy_tools", "DEFERRED_MODULES"]

#: Modules whose code runs at their first attribute access instead of at import.
DEFERRED_MODULES = frozenset({"numpy.f2py", "numpy.testing"})


class _DeferredFinder(importlib.abc.MetaPathFinder):
    """Finds `DEFERRED_MODULES` as the path finder does, with a lazy loader."""

    def find_spec(self, fullname, path, target=None):
        if fullname not in DEFERRED_MODULES:
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path, target)
        if spec is None or spec.loader is None:
            return None
        spec.loader = importlib.util.LazyLoader(spec.loader)
        return spec


def defer_numpy_tools() -> None:
    """Install the lazy finder of `DEFERRED_MODULES` (once per process; modules already
    imported stay as they are)."""
    if not any(isinstance(finder, _DeferredFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, _DeferredFinder())
