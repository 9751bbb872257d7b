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

`plain_scipy_docstrings` spares a second start-up cost of SciPy: its decorators rewrite
the docstrings of the functions they wrap while SciPy's modules are imported (the array-API
notes of every ``scipy.special`` function, the batching note of every ``scipy.linalg``
one): each parses the docstring with ``scipy._lib._docscrape.FunctionDoc`` and renders it
again, ~170 parses at every ``railnav run``, 0.14 s of ``import scipy.linalg,
scipy.special`` (0.43 → 0.29 s wall, load ~3). Installed, ``FunctionDoc`` (as loaded
into that module, when it is) is a subclass that parses nothing: the sections read empty,
edits to them are dropped, and it renders the function's own docstring. The functions
are SciPy's own, their docstrings SciPy's text without those added notes; nothing a
command computes reads them. The command line installs it with `defer_numpy_tools`.
"""
from __future__ import annotations

import copy
import importlib.abc
import importlib.machinery
import importlib.util
import inspect
import sys

__all__ = ["defer_numpy_tools", "plain_scipy_docstrings", "DEFERRED_MODULES",
           "SCIPY_DOCSCRAPE"]

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


#: SciPy's docstring parser, whose ``FunctionDoc`` `plain_scipy_docstrings` replaces.
SCIPY_DOCSCRAPE = "scipy._lib._docscrape"


def _unparsed(base: type) -> type:
    """A subclass of SciPy's ``FunctionDoc`` `base` that does not parse (module docstring):
    its sections are `base`'s empty defaults and it renders as a signature line (which
    SciPy's decorators cut off) and the function's own docstring."""

    class UnparsedFunctionDoc(base):
        def __init__(self, func, role="func", doc=None, config=None):
            if doc is None and func is None:
                raise ValueError("No function or docstring given")
            self._f, self._role = func, role
            self._text = (inspect.getdoc(func) or "") if doc is None else doc
            self._parsed_data = copy.deepcopy(base.sections)

        def __str__(self, func_role=""):
            return "\n" + self._text

    return UnparsedFunctionDoc


class _PatchingLoader(importlib.abc.Loader):
    """`loader`, then `patch(module)` once the module's code has run."""

    def __init__(self, loader, patch) -> None:
        self._loader, self._patch = loader, patch

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module) -> None:
        self._loader.exec_module(module)
        self._patch(module)

    def __getattr__(self, name):            # get_source, is_package ...: the loader's
        return getattr(self._loader, name)


def _patch_docscrape(module) -> None:
    base = getattr(module, "FunctionDoc", None)
    if isinstance(base, type) and isinstance(getattr(base, "sections", None), dict):
        module.FunctionDoc = _unparsed(base)     # (another SciPy: left as it is)


class _DocscrapeFinder(importlib.abc.MetaPathFinder):
    """Finds `SCIPY_DOCSCRAPE` as the path finder does, its ``FunctionDoc`` replaced."""

    def find_spec(self, fullname, path, target=None):
        if fullname != SCIPY_DOCSCRAPE:
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path, target)
        if spec is None or spec.loader is None:
            return None
        spec.loader = _PatchingLoader(spec.loader, _patch_docscrape)
        return spec


def plain_scipy_docstrings() -> None:
    """Install the finder of `SCIPY_DOCSCRAPE` (module docstring; once per process: a
    SciPy already imported stays as it is)."""
    if not any(isinstance(finder, _DocscrapeFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, _DocscrapeFinder())
