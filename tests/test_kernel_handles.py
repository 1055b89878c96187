"""Kernel calls are typed: every ``lazy()`` kernel handle in the package is shadowed, for the
type checker, by an import of the same kernel module under ``TYPE_CHECKING``, so that mypy
checks the call against the kernel's signature and go-to-definition reaches the kernel; at
run time the handle stays lazy (``redservo run`` imports numba only after the kernel-mode
choice, tests/test_kernel_mode.py)."""

from __future__ import annotations

import ast
from pathlib import Path

import redservo

SRC = Path(redservo.__file__).resolve().parent


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _typed_names(body: list[ast.stmt]) -> dict[str, str]:
    """``alias -> kernel module`` of the ``from redservo.kernels import m as alias`` in body."""
    out = {}
    for node in body:
        if isinstance(node, ast.ImportFrom) and node.module == "redservo.kernels":
            out.update({a.asname or a.name: a.name for a in node.names})
    return out


def _handle(node: ast.AST) -> tuple[str, str] | None:
    """``(name, module)`` when ``node`` is ``name = lazy("module")``."""
    if not (isinstance(node, ast.Assign) and len(node.targets) == 1):
        return None
    call, target = node.value, node.targets[0]
    if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name)):
        return None
    if call.func.id != "lazy" or not isinstance(target, ast.Name) or len(call.args) != 1:
        return None
    arg = call.args[0]
    if not (isinstance(arg, ast.Constant) and isinstance(arg.value, str)):
        return None
    return target.id, arg.value


def _untyped_handles(tree: ast.Module) -> list[str]:
    """The ``name = lazy("module")`` assignments not in the ``else`` of an
    ``if TYPE_CHECKING:`` that imports the same kernel module as the same name."""
    typed: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            names = _typed_names(node.body)
            for stmt in node.orelse:
                h = _handle(stmt)
                if h is not None and names.get(h[0]) == h[1]:
                    typed.add(id(stmt))
    bad = []
    for node in ast.walk(tree):
        h = _handle(node)
        if h is not None and id(node) not in typed:
            bad.append(f"{h[0]} = lazy({h[1]!r}) (line {getattr(node, 'lineno', 0)})")
    return bad


def test_every_lazy_kernel_handle_is_typed() -> None:
    bad = []
    for path in sorted(SRC.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bad += [f"{path.relative_to(SRC)}: {b}" for b in _untyped_handles(tree)]
    assert bad == []


def test_the_scan_finds_an_untyped_handle() -> None:
    src = (
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from redservo.kernels import features as _K\n"
        "else:\n    _K = lazy('features')\n"
        "_KI = lazy('interp')\n"
        "if TYPE_CHECKING:\n    from redservo.kernels import qp as _KQ\n"
        "else:\n    _KQ = lazy('boxqp')\n"
    )
    assert _untyped_handles(ast.parse(src)) == [
        "_KI = lazy('interp') (line 6)",
        "_KQ = lazy('boxqp') (line 10)",
    ]
