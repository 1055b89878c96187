"""MC05 reproduction (experiments 1 and 2) and the ``features[i].components`` scenario option."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from redservo.errors import ScenarioError
from redservo.experiment import build
from redservo.scenario import parse_scenario

_POINTS = [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]


def _moments_scenario(**feature: Any) -> dict[str, Any]:
    return {
        "robot": {"model": "afma6", "q0": [0.025, -0.04, -0.02, 0.0, 1.19, 0.0]},
        "objects": [
            {
                "name": "target",
                "kind": "points",
                "points": _POINTS,
                "pose_in_camera": {"translation": [0.05, -0.02, 0.8], "rotvec": [0.1, -0.1, 0.3]},
            }
        ],
        "features": [{"kind": "moments", "object": "target", **feature}],
        "task": {"desired_pose": {"translation": [0.0, 0.0, 0.6]}},
        "control": {"method": "classical"},
    }


def _state(data: dict[str, Any]) -> Any:
    exp = build(parse_scenario(data))
    J = exp.robot.jacobian(exp.q0)
    return exp, exp.task.evaluate(exp.scene, exp.robot.fkine(exp.q0), J, 0.0), J


def test_components_select_rows_of_the_error_and_jacobian() -> None:
    exp_all, full, J = _state(_moments_scenario())
    exp, sub, _ = _state(_moments_scenario(components=[3, 0, 1, 2]))
    assert exp_all.task.m == 6 and exp.task.m == 4
    np.testing.assert_allclose(sub.s, full.s)  # s is still measured in full
    np.testing.assert_allclose(sub.e1, full.e[:4], atol=1e-12)
    np.testing.assert_allclose(sub.J1, (full.L @ J)[:4], atol=1e-12)


def test_components_apply_to_each_point_of_a_point_entry() -> None:
    data = {
        "robot": {"model": "afma6", "q0": [0.025, -0.04, -0.02, 0.0, 1.19, 0.0]},
        "objects": [
            {
                "name": "p",
                "kind": "points",
                "points": [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]],
                "pose_in_camera": {"translation": [0.0, 0.0, 1.0]},
            }
        ],
        "features": [{"kind": "point", "object": "p", "components": [1]}],
        "task": {"desired": [0.0, 0.0, 0.0, 0.0]},
        "control": {"method": "classical"},
    }
    _, st, _ = _state(data)
    np.testing.assert_allclose(st.e1, st.e[[1, 3]])


@pytest.mark.parametrize("bad", [[], [6], [-1], [0, 0], [0.5], [True]])
def test_bad_components_name_the_key(bad: list[Any]) -> None:
    with pytest.raises(ScenarioError, match=r"features\[0\]\.components"):
        parse_scenario(copy.deepcopy(_moments_scenario(components=bad)))
