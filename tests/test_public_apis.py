"""The public APIs of `gnss_obs` and `strapdown`: every name in a package's `__all__` is
the object of the module that owns it (reference: that module, imported directly), its
main entry points are the real functions (not wrappers; a builder may be cached), and
importing the package loads none of its heavy dependencies (reference: a fresh
interpreter's ``sys.modules``)."""
from __future__ import annotations

import importlib
import inspect
import subprocess
import sys

import pytest

import gnss_obs
import strapdown
from tests.conftest import REPO

#: Package -> (its entry points and the modules that define them, heavy dependencies that
#: only its submodules may import).
APIS = {
    gnss_obs: ([("read_rinex_obs", "rinex_obs"), ("read_rinex_nav", "rinex_nav"),
                ("solve_spp", "spp"), ("read_sp3", "sp3"), ("simulate_gnss", "simulate")],
               ("casadi", "scipy", "pandas")),
    strapdown: ([("build_reduced_model", "reduced"), ("build_full_model", "mechanization"),
                 ("read_imu_csv", "imu"), ("imu_grade", "imu_errors")],
                ("casadi", "scipy")),
}


@pytest.mark.parametrize(("package", "name"),
                         [(p, n) for p in APIS for n in p.__all__],
                         ids=lambda v: getattr(v, "__name__", v))
def test_public_name_is_its_owners_object(package, name):
    owner = importlib.import_module(f"{package.__name__}.{package._EXPORTS[name]}")
    assert name in owner.__all__
    assert getattr(package, name) is getattr(owner, name)
    assert name in dir(package)


@pytest.mark.parametrize(("package", "name", "module"),
                         [(p, n, m) for p, (mains, _) in APIS.items() for n, m in mains],
                         ids=lambda v: getattr(v, "__name__", v))
def test_main_entry_points_are_the_real_functions(package, name, module):
    function = getattr(package, name)
    assert inspect.isfunction(inspect.unwrap(function))
    assert inspect.unwrap(function).__module__ == f"{package.__name__}.{module}"


@pytest.mark.parametrize("package", list(APIS), ids=lambda p: p.__name__)
def test_unknown_name_is_an_attribute_error(package):
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        package.no_such_name  # noqa: B018


@pytest.mark.parametrize("package", list(APIS), ids=lambda p: p.__name__)
def test_import_loads_no_heavy_dependency(package):
    heavy = APIS[package][1]
    code = (f"import {package.__name__}, sys; "
            f"print([m in sys.modules for m in {heavy!r}])")
    run = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                         text=True, check=True)
    assert run.stdout.strip() == str([False] * len(heavy))
