"""Obstacles in the compiled campaign loop (kernels/loop_avoid.py, campaign/loop_avoid.py):
the rows of panda-posts are those of the object path, bit for bit, and the runs stay on the
compiled loop, ``qp`` and ``sns`` with their velocity-damper rows too, solved in the loop by
the kernels the law objects call (kernels/rowqp.py, kernels/sns_rows.py): no step is handed
back to Python for its rows (campaign/loop_handback.py).

The first test in a fresh checkout compiles the loop (minutes, then cached on disk).
"""

from __future__ import annotations

import pytest

pytest.importorskip("numba", reason="the compiled campaign loop needs numba (redservo[fast])")

from dataclasses import replace
from typing import Any

from redservo.campaign import load_campaign, run_campaign
from redservo.campaign.engine import FAST_PATH
from redservo.scenario import apply_overrides


def _same_rows(a: tuple[dict[str, Any], ...], b: tuple[dict[str, Any], ...]) -> bool:
    """Every field equal, floats by their repr (bit for bit, NaN equal to NaN)."""

    def exact(rows: tuple[dict[str, Any], ...]) -> list[dict[str, Any]]:
        return [{k: repr(v) if isinstance(v, float) else v for k, v in r.items()} for r in rows]

    return exact(a) == exact(b)


def _variant(name: str, *sets: str) -> Any:
    d = load_campaign(name)
    return replace(d, scenario=apply_overrides(d.scenario, list(sets))) if sets else d


AVOIDING = ("classical", "gpm-auto", "iterative-smooth", "directional", "wln", "large-projection")
"""Laws that avoid through their secondary term and the distance shield: compiled."""


def _count_hand_backs(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Steps the loop hands back to the law in Python, per method, from now on."""
    from redservo.campaign import loop_handback

    counts: dict[str, int] = {}
    step = loop_handback.python_step

    def counted(exp: Any, law: Any, *args: Any) -> None:
        counts[law.name] = counts.get(law.name, 0) + 1
        step(exp, law, *args)

    monkeypatch.setattr(loop_handback, "python_step", counted)
    return counts


def test_posts_with_avoidance_rows_are_those_of_the_object_path(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The repulsion, the damper rows of qp and sns, the shield (its check on the true
    geometry) and the distance records in the loop: the same rows as the object path, every
    run on the loop, and no step handed back to Python (qp and sns solve their rows in the
    loop with the laws' own kernels)."""
    d = _variant("panda-posts")
    methods = [*AVOIDING, "sns", "qp"]
    counts = _count_hand_backs(monkeypatch)
    fast = run_campaign(d, samples=3, methods=methods, workers=1, progress=False)
    slow = run_campaign(d, samples=3, methods=methods, workers=1, progress=False, fast=False)
    assert _same_rows(fast.rows, slow.rows)
    for m in methods:
        assert fast.engines[m] == {FAST_PATH: 3}, m
    assert counts == {}
    assert all(r["min_distance"] >= 0.02 for r in fast.rows)
    assert any(r["flags"] and "distance-shield-acted" in r["flags"] for r in fast.rows)


def test_posts_without_avoidance_count_the_same_collisions() -> None:
    """The obstacles only measured: every compiled law on the loop (qp and sns too), the
    same rows, a run ending in ``collision`` among them."""
    d = _variant("panda-posts", "collision.enabled=false")
    methods = ["gpm", "wln", "sns", "qp"]
    fast = run_campaign(d, samples=3, methods=methods, workers=1, progress=False)
    slow = run_campaign(d, samples=3, methods=methods, workers=1, progress=False, fast=False)
    assert _same_rows(fast.rows, slow.rows)
    assert all(fast.engines[m] == {FAST_PATH: 3} for m in methods)


def test_qp_solves_its_rows_without_daqp(monkeypatch: pytest.MonkeyPatch) -> None:
    """qp's rows are solved by the compiled solver on both paths: with daqp made unavailable
    the rows are those of a run with it, and nothing is handed back."""
    from redservo.redundancy import bls

    d = _variant("panda-posts")
    ref = run_campaign(d, samples=2, methods=["qp"], workers=1, progress=False)
    monkeypatch.setattr(bls, "daqp_once", lambda: None)
    counts = _count_hand_backs(monkeypatch)
    fast = run_campaign(d, samples=2, methods=["qp"], workers=1, progress=False)
    slow = run_campaign(d, samples=2, methods=["qp"], workers=1, progress=False, fast=False)
    assert _same_rows(fast.rows, ref.rows) and _same_rows(fast.rows, slow.rows)
    assert fast.engines["qp"] == {FAST_PATH: 2} and counts == {}
