"""Obstacles in the compiled campaign loop (kernels/loop_avoid.py, campaign/loop_avoid.py):
the rows of panda-posts are those of the object path, bit for bit, and the runs stay on the
compiled loop, ``qp`` and ``sns`` with their velocity-damper rows too (kernels/loop_rows.py:
a step the rows change is computed by the law in Python, campaign/loop_handback.py).

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
    run on the loop; qp and sns hand the steps their rows change back to the law."""
    d = _variant("panda-posts")
    methods = [*AVOIDING, "sns", "qp"]
    counts = _count_hand_backs(monkeypatch)
    fast = run_campaign(d, samples=3, methods=methods, workers=1, progress=False)
    slow = run_campaign(d, samples=3, methods=methods, workers=1, progress=False, fast=False)
    assert _same_rows(fast.rows, slow.rows)
    for m in methods:
        assert fast.engines[m] == {FAST_PATH: 3}, m
    assert counts.get("qp", 0) > 0 and counts.get("sns", 0) > 0
    assert set(counts) == {"qp", "sns"}
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


def test_qp_without_daqp_drops_its_rows_on_both_paths(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without daqp the object path's qp drops its rows (with a note); the loop builds none
    and hands nothing back for them: the same rows, every run on the loop."""
    from redservo.campaign import loop_avoid
    from redservo.redundancy import distance_rows

    monkeypatch.setattr(loop_avoid, "daqp_once", lambda: None)
    monkeypatch.setattr(distance_rows, "daqp_once", lambda: None)
    counts = _count_hand_backs(monkeypatch)
    d = _variant("panda-posts")
    fast = run_campaign(d, samples=2, methods=["qp"], workers=1, progress=False)
    slow = run_campaign(d, samples=2, methods=["qp"], workers=1, progress=False, fast=False)
    assert _same_rows(fast.rows, slow.rows)
    assert fast.engines["qp"] == {FAST_PATH: 2} and counts == {}
