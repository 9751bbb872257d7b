"""The import graph of the library packages, and its circles.

Every ``import`` statement counts, wherever it stands: at module level, inside a function,
or under ``if TYPE_CHECKING:`` (a circle hidden there is still a circle of the design).
An edge ``a -> b`` means that module ``a`` names module ``b`` in an import: ``import
pkg.mod``, ``from pkg.mod import name`` (``pkg.mod``, or ``pkg.mod.name`` when that is a
module), relative imports alike. The implicit import of the parent packages of ``b`` is
not an edge (every package's ``__init__`` would otherwise be in a circle with its own
modules). Names loaded by a package's PEP 562 ``__getattr__`` are not edges either.

Run from the repository root::

    python -m tests.support.import_graph            # trackmodel strapdown gnss_obs ekf
    python -m tests.support.import_graph ekf        # one package

It prints each circle and exits 1 if there is one, 0 otherwise. The test suite checks
the same property, and the dependency rules between packages, for the whole repository
in ``tests/test_import_graph.py``.
"""
from __future__ import annotations

import ast
import sys
from collections.abc import Iterable
from pathlib import Path

__all__ = ["LIBRARY_PACKAGES", "REPO", "import_graph", "circles", "main"]

REPO = Path(__file__).resolve().parents[2]
#: The library packages (ARCHITECTURE.md), lowest first.
LIBRARY_PACKAGES = ("trackmodel", "ekf", "strapdown", "gnss_obs")


def _modules(packages: Iterable[str], root: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` file of the packages."""
    out = {}
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def _targets(node: ast.AST, name: str, is_package: bool) -> list[str]:
    """The dotted names one import statement of module ``name`` refers to."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    assert isinstance(node, ast.ImportFrom)
    if node.level:
        base = name.split(".")
        base = base if is_package else base[:-1]
        base = base[:len(base) - (node.level - 1)]
        stem = ".".join(base + ([node.module] if node.module else []))
    else:
        stem = node.module or ""
    return [stem] + [f"{stem}.{alias.name}" for alias in node.names]


def import_graph(packages: Iterable[str] = LIBRARY_PACKAGES, *,
                 root: Path = REPO) -> dict[str, set[str]]:
    """Module -> the modules of any package under ``root`` that it imports.

    Parameters
    ----------
    packages : iterable of str
        Top-level packages whose modules are the nodes.
    root : Path
        Directory that holds the packages (the repository root).

    Returns
    -------
    dict of str to set of str
        Edges to every importable module under ``root`` (also of other packages); module
        names are dotted, a package is its ``__init__``.
    """
    modules = _modules(packages, root)
    graph = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        edges = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for target in _targets(node, name, path.name == "__init__.py"):
                    rel = Path(*target.split("."))
                    if target and ((root / rel).with_suffix(".py").is_file()
                                   or (root / rel / "__init__.py").is_file()):
                        edges.add(target)
        edges.discard(name)
        graph[name] = edges
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def main(argv: list[str] | None = None) -> int:
    """Print the circles among the modules of the packages; 1 if any, else 0."""
    packages = (argv if argv is not None else sys.argv[1:]) or list(LIBRARY_PACKAGES)
    found = circles(import_graph(packages))
    for component in found:
        print("circle: " + " <-> ".join(component))
    print(f"{len(found)} import circle(s) among the modules of {', '.join(packages)}")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
