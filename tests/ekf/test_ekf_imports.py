"""The imports of `ekf`: no circle among its modules, and only the packages of the
project that ARCHITECTURE.md allows. Reference: the import statements themselves, read
with `ast` (module-level, function-local and TYPE_CHECKING imports alike)."""
from __future__ import annotations

from tests.support.import_graph import (ALLOWED_DEPENDENCIES, circles, import_graph,
                                        package_dependencies)

PACKAGE = "ekf"


def test_no_import_circle_among_modules():
    assert circles(import_graph([PACKAGE])) == []


def test_imports_only_allowed_packages():
    used = package_dependencies(import_graph([PACKAGE])).get(PACKAGE, set())
    assert used <= ALLOWED_DEPENDENCIES[PACKAGE]
