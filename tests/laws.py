"""Test helper: the papers' laws exactly as printed (no shield, no robust inverse)."""

from __future__ import annotations

from typing import Any

from redservo.redundancy import Law, make_law


def paper_law(name: str, **options: Any) -> Law:
    """``make_law(name, shield=False, robust=False, **options)``: the formula under test."""
    options.setdefault("shield", False)
    options.setdefault("robust", False)
    return make_law(name, **options)
