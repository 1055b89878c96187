"""The compiled reachability search (redservo.kernels.reach): the verdicts of the Python
search on the shipped campaigns, without Python in the loop."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import redservo.campaign.reach as reach
from redservo.campaign import draw_sample, load_campaign
from redservo.campaign.task import _reachable
from redservo.experiment.build import build
from redservo.spatial import matrix_to_rotvec, rotvec_to_matrix

VERDICTS = json.loads((Path(__file__).parent / "data" / "reach_verdicts.json").read_text())
"""Per shipped campaign, the ``reachable`` column of its first 200 samples (seed 0) as the
Python search of redservo 0.x (main at a9e79a6) computed it: T, F, or - (no desired pose);
panda-posts since its goals must be clear of the obstacles (campaign/reach_obstacles.py: 4 of
its 137 reachable samples became unreachable)."""


def _column(name: str, count: int) -> str:
    defn = load_campaign(name)
    out = []
    for i in range(count):
        try:
            exp = build(draw_sample(defn, 0, i).scenario)
        except Exception:  # as run_job: the column is then unknown
            exp = None
        out.append({"True": "T", "False": "F", "": "-"}[_reachable(exp)])
    return "".join(out)


def test_every_shipped_campaign_has_stored_verdicts() -> None:
    from redservo.campaign.definition import shipped_campaigns

    assert sorted(VERDICTS) == sorted(shipped_campaigns())


@pytest.mark.parametrize("name", sorted(VERDICTS))
def test_same_verdicts_as_the_python_search_on_200_samples(name: str) -> None:
    """Reachable and unreachable samples alike (132/68 on the Panda campaigns, 94/106 on
    mc05-joint-limits, whose unreachable ones go through the feature stage)."""
    assert _column(name, len(VERDICTS[name])) == VERDICTS[name]


def _sample(name: str, verdict: str) -> object:
    """The first sample of campaign ``name`` whose stored verdict is ``verdict``."""
    i = VERDICTS[name].index(verdict)
    return build(draw_sample(load_campaign(name), 0, i).scenario)


@pytest.mark.parametrize("name", ["panda-near-limits", "panda-urdf-near-limits"])
def test_the_pose_search_is_compiled(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """An unreachable sample tries every seed in both stages without the Python search."""

    def python_search(*args: object, **kw: object) -> None:
        raise AssertionError("the Python search ran")

    monkeypatch.setattr(reach, "solve_ik", python_search)
    monkeypatch.setattr(reach, "feature_solution", python_search)
    assert reach.reachable(_sample(name, "F")) is False
    assert reach.reachable(_sample(name, "T")) is True


def test_the_feature_stage_is_compiled(monkeypatch: pytest.MonkeyPatch) -> None:
    """mc05-joint-limits (the Afma6, image points): its unreachable samples search on ``e1``."""

    def python_search(*args: object, **kw: object) -> None:
        raise AssertionError("the Python search ran")

    monkeypatch.setattr(reach, "feature_solution", python_search)
    assert reach.reachable(_sample("mc05-joint-limits", "F")) is False


def test_a_robot_without_compiled_kinematics_keeps_the_python_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The search falls back to Python for robots the compiled loop does not cover."""
    import redservo.campaign.looppack as looppack

    calls = []
    solve = reach.solve_ik

    def counted(*args: object, **kw: object) -> object:
        calls.append(1)
        return solve(*args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(looppack, "robot_reason", lambda exp: "no compiled kinematics")
    monkeypatch.setattr(reach, "solve_ik", counted)
    assert reach.reachable(_sample("panda-near-limits", "T")) is True
    assert calls


@pytest.mark.parametrize("angle", [0.0, 1e-8, 0.3, 2.0, math.pi - 2e-3, math.pi - 1e-5, math.pi])
@pytest.mark.parametrize("compiled", [True, False])
def test_theta_u_is_the_rotation_vector(angle: float, compiled: bool) -> None:
    """Away from and near θ = π (the branch :func:`redservo.robots.ik._theta_u` hands to scipy)."""
    from redservo.kernels.reach import theta_u

    fn = theta_u if compiled else getattr(theta_u, "py_func", theta_u)
    rng = np.random.default_rng(3)
    for _ in range(20):
        axis = rng.normal(size=3)
        r = angle * axis / np.linalg.norm(axis)
        R = np.ascontiguousarray(rotvec_to_matrix(r))
        got = fn(R)
        want = matrix_to_rotvec(R)
        if angle > math.pi - 1e-6:  # θ = π: u and -u are the same rotation
            assert np.allclose(rotvec_to_matrix(got), R, atol=1e-9)
        else:
            assert np.allclose(got, want, atol=1e-9)


def test_singular_damped_system_gives_up_the_seed() -> None:
    """A zero or NaN pivot: NaN (numpy's solve raises, the Python search gives up the seed)."""
    from redservo.kernels.reach import _solve, projected_step

    assert np.all(np.isnan(_solve(np.zeros((3, 3)), np.ones(3))))
    x = _solve(np.array([[0.0, 2.0], [1.0, 1.0]]), np.array([2.0, 3.0]))
    assert np.allclose(x, [2.0, 1.0])
    J = np.full((6, 7), np.nan)
    q = np.zeros(7)
    _, ok = projected_step(J, np.ones(6), q, q - 1.0, q + 1.0, 1e-3, 0.5)
    assert not ok


def test_warm_up_compiles_both_stages(monkeypatch: pytest.MonkeyPatch) -> None:
    """``redservo warmup`` runs the pose and the feature stage once (one seed); a task
    without a desired pose has no search."""
    import redservo.kernels.reach as kernels

    calls: list[str] = []
    for name in ("pose_search", "feature_search"):
        real = getattr(kernels, name)

        def spy(*args: object, _real: Any = real, _name: str = name) -> Any:
            calls.append(_name)
            assert args[-4 if _name == "feature_search" else -3].shape[0] == 1  # type: ignore[attr-defined]
            return _real(*args)

        monkeypatch.setattr(kernels, name, spy)
    reach.compile_search(_sample("mc05-joint-limits", "T"))
    assert calls == ["pose_search", "feature_search"]
    reach.compile_search(build(draw_sample(load_campaign("cm01-gaze"), 0, 0).scenario))
    assert calls == ["pose_search", "feature_search"]
