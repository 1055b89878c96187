"""A griffe extension for the API reference (mkdocs.yml): the docstrings use Sphinx roles
(:class:`~redservo.control.Controller`, :func:`make_law`), which Markdown would show as
they are; each becomes a code span of the name (the last component with ``~``)."""

from __future__ import annotations

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


class SphinxRoles(griffe.Extension):
    """Rewrite the Sphinx roles of every docstring as Markdown code spans."""

    def on_instance(self, *, obj: Any, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _ROLE.sub(_name, obj.docstring.value)
