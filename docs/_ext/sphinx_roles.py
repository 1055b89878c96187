"""A griffe extension for the API reference (mkdocs.yml): the docstrings use Sphinx roles
(:class:`~redservo.control.Controller`, :func:`make_law`), which Markdown would show as
they are; each becomes a code span of the name (the last component with ``~``).

Two more rewrites for a readable reference:

* doctest blocks (``>>>`` lines and their output) become fenced ``pycon`` code blocks;
  Markdown would read each ``>`` as a quote and run the lines together;
* a module constant computed by an expression (``METHODS = tuple(...)``) shows its value,
  read from the imported module, instead of the expression's source."""

from __future__ import annotations

import importlib
import re
from typing import Any

import griffe

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|exc|obj|const|ref|term):`([^`]+)`")


def _name(match: re.Match[str]) -> str:
    text = match.group(1)
    if "<" in text and text.endswith(">"):  # "title <target>"
        text = text[: text.index("<")].strip()
    if text.startswith("~"):
        text = text[1:].rsplit(".", 1)[-1]
    return f"`{text}`"


def fence_doctests(text: str) -> str:
    """Wrap each doctest block of ``text`` (a ``>>>`` line and the non-blank lines after it)
    in a fenced ``pycon`` block at its indentation."""
    out: list[str] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line.lstrip().startswith(">>>"):
            out.append(line)
            i += 1
            continue
        indent = line[: len(line) - len(line.lstrip())]
        out.append(f"{indent}```pycon")
        while i < len(lines) and lines[i].strip():
            out.append(lines[i])
            i += 1
        out.append(f"{indent}```")
    return "\n".join(out)


_SHOWN = (str, int, float, bool, tuple, list, frozenset, dict)
_COMPUTED = ("ExprCall", "ExprListComp", "ExprDictComp", "ExprBinOp", "ExprGeneratorExp")


def _runtime_value(module: str, name: str) -> str | None:
    """``repr`` of ``module.name`` when it is a small plain value (None otherwise)."""
    try:
        value = getattr(importlib.import_module(module), name)
    except Exception:  # an unimportable module keeps its source expression
        return None
    text = repr(value)
    return text if isinstance(value, _SHOWN) and len(text) <= 3000 else None


class SphinxRoles(griffe.Extension):
    """Rewrite the Sphinx roles of every docstring as Markdown code spans, fence doctest
    blocks, and show computed module constants by value (module docstring)."""

    def on_instance(self, *, obj: Any, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = fence_doctests(_ROLE.sub(_name, obj.docstring.value))

    def on_attribute_instance(self, *, attr: Any, **kwargs: Any) -> None:
        value = attr.value
        if not attr.parent or not attr.parent.is_module or isinstance(value, str):
            return
        # a computed value, or only an annotation (a value a module __getattr__ gives)
        if value is not None and type(value).__name__ not in _COMPUTED:
            return
        shown = _runtime_value(attr.parent.path, attr.name)
        if shown is not None:
            attr.value = shown
