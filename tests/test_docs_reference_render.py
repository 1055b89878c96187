"""The API reference is readable: doctest blocks become fenced ``pycon`` code (Markdown read
each ``>`` as a nested quote and ran the lines together) and a computed constant such as
``METHODS`` shows its value instead of its source (docs/_ext/sphinx_roles.py, the griffe
extension of mkdocs.yml)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def ext() -> ModuleType:
    pytest.importorskip("griffe")
    spec = importlib.util.spec_from_file_location(
        "sphinx_roles", ROOT / "docs/_ext/sphinx_roles.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["sphinx_roles"] = module
    spec.loader.exec_module(module)
    return module


def test_doctest_blocks_become_fenced_pycon(ext: ModuleType) -> None:
    text = (
        "Start here.\n\n>>> import redservo\n>>> redservo.run('x').outcome\n'converged'\n\nAfter."
    )
    assert ext.fence_doctests(text) == (
        "Start here.\n\n```pycon\n>>> import redservo\n>>> redservo.run('x').outcome\n"
        "'converged'\n```\n\nAfter."
    )
    indented = "Example:\n    >>> 1 + 1\n    2"
    assert ext.fence_doctests(indented) == "Example:\n    ```pycon\n    >>> 1 + 1\n    2\n    ```"
    assert ext.fence_doctests("no example here") == "no example here"


def test_methods_shows_its_value_not_its_source(ext: ModuleType) -> None:
    import griffe

    from redservo import METHODS

    module = griffe.load(
        "redservo.redundancy",
        search_paths=[str(ROOT / "src")],
        extensions=griffe.load_extensions(ext.SphinxRoles),
    )
    value = str(module["METHODS"].value)
    assert value == repr(METHODS) and "for n in" not in value
    assert ext._runtime_value("redservo.no_such_module", "X") is None
