"""The public API of `strapdown`: every name in `__all__` is the object of the module that
owns it (reference: that module, imported directly), and ``import strapdown`` loads no
CasADi or SciPy (reference: a fresh interpreter's ``sys.modules``)."""
from __future__ import annotations

import importlib
import inspect
import subprocess
import sys

import pytest

import strapdown
from tests.conftest import REPO

#: Entry points and the modules that define them (not wrappers; a builder may be cached).
MAIN_FUNCTIONS = [("build_reduced_model", "reduced"), ("build_full_model", "mechanization"),
                  ("read_imu_csv", "imu"), ("imu_grade", "imu_errors")]
#: Heavy dependencies that only the submodules may import.
HEAVY_MODULES = ("casadi", "scipy")


@pytest.mark.parametrize("name", strapdown.__all__)
def test_public_name_is_its_owners_object(name):
    owner = importlib.import_module(f"strapdown.{strapdown._EXPORTS[name]}")
    assert name in owner.__all__
    assert getattr(strapdown, name) is getattr(owner, name)
    assert name in dir(strapdown)


@pytest.mark.parametrize(("name", "module"), MAIN_FUNCTIONS)
def test_main_entry_points_are_the_real_functions(name, module):
    function = getattr(strapdown, name)
    assert inspect.isfunction(inspect.unwrap(function))
    assert inspect.unwrap(function).__module__ == f"strapdown.{module}"


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        strapdown.no_such_name  # noqa: B018


def test_import_loads_no_heavy_dependency():
    code = f"import strapdown, sys; print([m in sys.modules for m in {HEAVY_MODULES!r}])"
    run = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                         text=True, check=True)
    assert run.stdout.strip() == str([False] * len(HEAVY_MODULES))
