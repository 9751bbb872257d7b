"""The public API of `gnss_obs`: every name in `__all__` is the object of the module that
owns it (reference: that module, imported directly), and ``import gnss_obs`` loads no
CasADi, SciPy or pandas (reference: a fresh interpreter's ``sys.modules``)."""
from __future__ import annotations

import importlib
import inspect
import subprocess
import sys

import pytest

import gnss_obs
from tests.conftest import REPO

#: Entry points and the modules that define them (not wrappers; a builder may be cached).
MAIN_FUNCTIONS = [("read_rinex_obs", "rinex_obs"), ("read_rinex_nav", "rinex_nav"),
                  ("solve_spp", "spp"), ("read_sp3", "sp3"), ("simulate_gnss", "simulate")]
#: Heavy dependencies that only the submodules may import.
HEAVY_MODULES = ("casadi", "scipy", "pandas")


@pytest.mark.parametrize("name", gnss_obs.__all__)
def test_public_name_is_its_owners_object(name):
    owner = importlib.import_module(f"gnss_obs.{gnss_obs._EXPORTS[name]}")
    assert name in owner.__all__
    assert getattr(gnss_obs, name) is getattr(owner, name)
    assert name in dir(gnss_obs)


@pytest.mark.parametrize(("name", "module"), MAIN_FUNCTIONS)
def test_main_entry_points_are_the_real_functions(name, module):
    function = getattr(gnss_obs, name)
    assert inspect.isfunction(inspect.unwrap(function))
    assert inspect.unwrap(function).__module__ == f"gnss_obs.{module}"


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        gnss_obs.no_such_name  # noqa: B018


def test_import_loads_no_heavy_dependency():
    code = f"import gnss_obs, sys; print([m in sys.modules for m in {HEAVY_MODULES!r}])"
    run = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                         text=True, check=True)
    assert run.stdout.strip() == str([False] * len(HEAVY_MODULES))
