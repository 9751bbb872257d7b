"""The import graph of the whole repository: no circle, and the dependency rules hold.

The graph is read from the source (every ``import`` statement, at module level or inside a
function, with ``if TYPE_CHECKING`` blocks included), so an import moved into a function
or behind ``TYPE_CHECKING`` still counts: a circle cannot be hidden. Reference: Tarjan's
strongly connected components (`graphlib.TopologicalSorter` raises `CycleError` on a
circle, a second method).
"""
from __future__ import annotations

import ast
import graphlib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: Our packages, as imported (``data/`` installs as ``railnav_data``).
PACKAGES = {"trackmodel": "trackmodel", "strapdown": "strapdown", "gnss_obs": "gnss_obs",
            "ekf": "ekf", "railnav": "railnav", "railnav_data": "data"}
#: Which of our packages each package may import (ARCHITECTURE.md, dependency direction).
ALLOWED = {
    "railnav_data": set(),
    "ekf": set(),
    "trackmodel": {"railnav_data"},
    "strapdown": {"trackmodel", "ekf"},
    "gnss_obs": {"trackmodel", "railnav_data"},
    "railnav": {"trackmodel", "strapdown", "gnss_obs", "ekf", "railnav_data"},
}


def _modules() -> dict[str, Path]:
    out = {}
    for package, folder in PACKAGES.items():
        for path in sorted((REPO / folder).rglob("*.py")):
            rel = path.relative_to(REPO / folder).with_suffix("")
            parts = [package, *rel.parts]
            if parts[-1] == "__init__":
                parts = parts[:-1]
            elif len(rel.parts) > 1 and folder == "data":
                continue            # build scripts beside the shipped files
            out[".".join(parts)] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Our modules that `name` imports (a ``from P import m`` of a submodule counts as m)."""
    is_package = path.name == "__init__.py"
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                here = name.split(".") if is_package else name.split(".")[:-1]
                here = here[:len(here) - (node.level - 1)]
                base = ".".join(here + ([base] if base else []))
            targets = [base] + [f"{base}.{a.name}" for a in node.names]
        for target in targets:
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm (iterative): components with more than one module, or a module
    importing itself."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    out.append(sorted(component))
    return out


def test_the_graph_covers_every_package(graph):
    for package in PACKAGES:
        assert package in graph, package
    assert len(graph) > 150          # ~200 modules: the walk found the tree


def test_no_import_circle(graph):
    assert _strongly_connected(graph) == []
    list(graphlib.TopologicalSorter(graph).static_order())     # raises CycleError on a circle


def test_tarjan_finds_a_planted_circle(graph):
    planted = {k: set(v) for k, v in graph.items()}
    assert "railnav.errors" in planted["railnav.config"]
    planted["railnav.errors"].add("railnav.config")
    circles = _strongly_connected(planted)
    assert any({"railnav.config", "railnav.errors"} <= set(c) for c in circles)
    with pytest.raises(graphlib.CycleError):
        list(graphlib.TopologicalSorter(planted).static_order())


def test_dependency_rules(graph):
    broken = sorted((a, b) for a, targets in graph.items() for b in targets
                    if (pa := a.split(".")[0]) != (pb := b.split(".")[0])
                    and pb not in ALLOWED[pa])
    assert broken == []


def test_nothing_outside_railnav_imports_it(graph):
    assert not [a for a, targets in graph.items() if not a.startswith("railnav.")
                and a != "railnav" and any(t.split(".")[0] == "railnav" for t in targets)]


def test_railnav_top_level_is_small_and_documented():
    top = sorted(p.name for p in (REPO / "railnav").glob("*.py"))
    assert len(top) <= 12, top
    for init in (REPO / "railnav").glob("*/__init__.py"):
        doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8")))
        assert doc and len(doc) > 40, f"{init}: no docstring saying what it owns"
