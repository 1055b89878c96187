"""The layer rules of the package (docs/architecture.md), checked on the source's AST.

Every import counts: module-level ones, those inside functions (lazy imports), those under
``if TYPE_CHECKING:``, and the package ``__init__`` a ``from redservo.a.b import x`` runs
(``redservo.a``, ``redservo.a.b``). Two rules:

* the kernel layer (``redservo.kernels``) imports nothing of redservo outside itself;
* no import cycle among redservo modules, lazy imports included. A module depends on the
  packages above it implicitly (Python imports them first); that alone is not a cycle, but
  an explicit import of its own package's ``__init__`` is an edge like any other.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "redservo"

KNOWN_CYCLES: tuple[str, ...] = ()
"""Packages whose internal cycles are known and being removed elsewhere: a cycle is tolerated
when all its modules are in one of them. Keep this short: it is meant to be empty."""


def _tolerated(cycle: frozenset[str], package: str) -> bool:
    return all(m == package or m.startswith(package + ".") for m in cycle)


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@cache
def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _is_package(name: str) -> bool:
    return _modules()[name].name == "__init__.py"


def _ancestors(name: str) -> list[str]:
    parts = name.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def _imported(name: str, node: ast.Import | ast.ImportFrom) -> Iterator[str]:
    """The redservo modules an import statement of module ``name`` names explicitly."""
    mods = _modules()
    if isinstance(node, ast.Import):
        for alias in node.names:
            if alias.name in mods:
                yield alias.name
        return
    if node.level:
        here = name if _is_package(name) else name.rpartition(".")[0]
        base = ".".join(here.split(".")[: len(here.split(".")) - node.level + 1])
        target = f"{base}.{node.module}" if node.module else base
    else:
        target = node.module or ""
    if target not in mods:
        return
    subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in mods]
    if len(subs) < len(node.names):  # names of the package's __init__ itself
        yield target
    else:  # only submodules: `from redservo import plots` runs redservo/__init__ as well
        if target not in _ancestors(name):
            yield target
    yield from subs


def _imports(
    tree: ast.AST, typing_only: bool = False
) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement of ``tree`` and whether it sits under ``if TYPE_CHECKING:``."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node, typing_only
        elif isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                yield from _imports(ast.Module(body=[child], type_ignores=[]), True)
            for child in node.orelse:
                yield from _imports(ast.Module(body=[child], type_ignores=[]), typing_only)
        else:
            yield from _imports(node, typing_only)


@cache
def import_graph(with_typing: bool = False) -> dict[str, dict[str, int]]:
    """Module -> {imported redservo module: first line}, with the implied package inits;
    ``with_typing``: also the imports under ``if TYPE_CHECKING:`` (they never run)."""
    graph: dict[str, dict[str, int]] = {}
    for name, path in _modules().items():
        edges: dict[str, int] = {}
        own = set(_ancestors(name))
        for node, typing_only in _imports(ast.parse(path.read_text(encoding="utf-8"))):
            if typing_only and not with_typing:
                continue
            for target in _imported(name, node):
                for dep in [*_ancestors(target), target]:
                    if dep == name or (dep in own and dep != target):
                        continue
                    edges.setdefault(dep, node.lineno)
        graph[name] = edges
    return graph


def import_cycles() -> list[frozenset[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    graph = import_graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[frozenset[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(frozenset(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _describe(comp: frozenset[str]) -> str:
    graph = import_graph()
    edges = [
        f"{a} -> {b} (line {graph[a][b]})" for a in sorted(comp) for b in graph[a] if b in comp
    ]
    return "; ".join(edges)


def test_the_kernel_layer_imports_nothing_above_it() -> None:
    bad = [
        f"{name} -> {dep} (line {line})"
        for name, edges in import_graph(with_typing=True).items()
        if name == "redservo.kernels" or name.startswith("redservo.kernels.")
        for dep, line in edges.items()
        if dep != "redservo"
        and not (dep == "redservo.kernels" or dep.startswith("redservo.kernels."))
    ]
    assert not bad, "kernels/ imports above itself: " + ", ".join(bad)


def test_the_servo_loop_does_not_import_the_simulator() -> None:
    """hardware/ (the real arm's loop) and simulation/ share records (redservo.records),
    not code paths."""
    graph = import_graph()
    found = {
        name: [
            d for d in edges if d == "redservo.simulation" or d.startswith("redservo.simulation.")
        ]
        for name, edges in graph.items()
        if name == "redservo.hardware" or name.startswith("redservo.hardware.")
    }
    bad = {k: v for k, v in found.items() if v}
    assert not bad, f"hardware/ imports simulation/: {bad}"


def test_the_graph_sees_lazy_and_package_imports() -> None:
    # the scan itself: a lazy import inside a function, and the package a submodule import runs
    graph = import_graph()
    assert "redservo.simulation" in graph["redservo.cli.common"]  # lazy, in warn()
    assert "redservo.kernels" in graph["redservo.redundancy.sns"]  # runs kernels/__init__
    assert "redservo.kernels.pack" in graph["redservo.kernels.sns"]


def test_no_import_cycle_beyond_the_known_ones() -> None:
    cycles = import_cycles()
    new = [c for c in cycles if not any(_tolerated(c, p) for p in KNOWN_CYCLES)]
    assert not new, "import cycles: " + " | ".join(_describe(c) for c in new)
    gone = [p for p in KNOWN_CYCLES if not any(_tolerated(c, p) for c in cycles)]
    assert not gone, f"no cycle left in {gone}: remove them from KNOWN_CYCLES"


def test_the_cycle_finder_finds_a_lazy_cycle(monkeypatch: pytest.MonkeyPatch) -> None:
    """The finder on a made-up graph: a lazy edge closing a loop through a package init."""
    graph = {
        "redservo.a": {"redservo.a.b": 3},
        "redservo.a.b": {"redservo.c": 7},
        "redservo.c": {"redservo.a": 12},  # e.g. `from redservo.a import x` inside a function
        "redservo.d": {"redservo.c": 1},
    }
    monkeypatch.setattr(sys.modules[__name__], "import_graph", lambda: graph)
    assert import_cycles() == [frozenset({"redservo.a", "redservo.a.b", "redservo.c"})]


def test_nothing_below_the_binding_imports_it() -> None:
    """The binding (objects -> kernels) sits above every module it imports, lazily or not."""
    graph = import_graph()
    below: set[str] = set()
    todo = [m for m in graph if m.startswith("redservo.binding")]
    while todo:
        for dep in graph[todo.pop()]:
            if not dep.startswith("redservo.binding") and dep not in below:
                below.add(dep)
                todo.append(dep)
    bad = [
        f"{m} -> {d}" for m in sorted(below) for d in graph[m] if d.startswith("redservo.binding")
    ]
    assert not bad, "modules the binding imports import it back: " + ", ".join(bad)


def test_the_scan_reads_lazy_typing_only_and_own_package_imports() -> None:
    tree = ast.parse(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from redservo.scene import Scene\n"
        "def f():\n"
        "    from redservo.reproduction import experiments\n"
        "    from . import registry\n"
    )
    found = [(getattr(n, "module", None), typing) for n, typing in _imports(tree)]
    assert found == [("typing", False), ("redservo.scene", True), ("redservo.reproduction", False),
                     (None, False)]  # fmt: skip
    here = "redservo.reproduction.robustness"
    lazy, relative = [n for n, _ in _imports(tree)][2:]
    # a module importing a name of its own package's __init__ depends on that __init__ ...
    assert list(_imported(here, lazy)) == ["redservo.reproduction"]
    # ... but a submodule import does not run the package's __init__ a second time
    assert list(_imported(here, relative)) == ["redservo.reproduction.registry"]
