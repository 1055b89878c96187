"""Scenario files: validation messages name the file, the key and what is allowed."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from redservo import ScenarioError
from redservo.experiment import build
from redservo.scenario import apply_overrides, load_scenario, parse_scenario, shipped_scenarios

GOOD = """
name = "mine"
description = "a user's own scenario"

[robot]
model = "afma6"
q0 = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0]

[[objects]]
name = "target"
kind = "points"
points = [[0.0, 0.0, 0.0]]
pose_in_camera = { translation = [0.1, 0.05, 0.8] }

[[features]]
kind = "point"
object = "target"

[task]
desired = [0.0, 0.0]

[control]
method = "iterative-smooth"
lam = 0.6
dt = 0.04

[simulation]
max_iterations = 300
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "my.toml"
    p.write_text(text)
    return p


def test_every_shipped_scenario_loads_and_builds() -> None:
    names = shipped_scenarios()
    assert "afma6-gaze-demo" in names
    for name in names:
        exp = build(load_scenario(name))
        assert exp.limits.contains(exp.q0)


def test_user_file_runs(tmp_path: Path) -> None:
    sc = load_scenario(_write(tmp_path, GOOD))
    assert sc.name == "mine" and sc.method == "iterative-smooth"
    res = build(sc).run()
    assert res.outcome == "converged"


@pytest.mark.parametrize(
    ("edit", "key", "hint"),
    [
        (lambda d: d["robot"].pop("model"), "robot.model", "missing"),
        (lambda d: d["robot"].__setitem__("model", "puma"), "robot.model", "afma6"),
        (
            lambda d: d["control"].__setitem__("method", "magic"),
            "control.method",
            "iterative-smooth",
        ),
        (lambda d: d["control"].__setitem__("lam", "fast"), "control.lam", "expected number"),
        (lambda d: d["features"][0].__setitem__("kind", "blob"), "features[0].kind", "cylinder"),
        (lambda d: d["features"][0].__setitem__("object", "ghost"), "features[0].object", "target"),
        (
            lambda d: d["robot"].__setitem__("q0", [9.0, 0, 0, 0, 1, 0]),
            "robot.q0",
            "outside the joint limits",
        ),
        (lambda d: d["robot"].__setitem__("q0", [0.0, 0.0]), "robot.q0", "shape"),
        (lambda d: d["robot"].__setitem__("qzero", [0.0]), "robot.qzero", "unknown key"),
        (lambda d: d["objects"][0].__setitem__("kind", "cube"), "objects[0].kind", "sphere"),
        (
            lambda d: d["control"].__setitem__("options", {"alfa": 1.0}),
            "control.options",
            "options are",
        ),
        (
            lambda d: d["objects"][0].__setitem__("pose_in_camera", {"translation": [0, 0, -1]}),
            "objects",
            "behind",
        ),
    ],
)
def test_validation_errors_name_file_key_and_allowed(
    tmp_path: Path, edit, key: str, hint: str
) -> None:
    data = tomllib.loads(GOOD)
    edit(data)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, "my.toml")
    msg = str(info.value)
    assert msg.startswith("my.toml: key '" + key), msg
    assert hint in msg, msg


def test_malformed_toml_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(_write(tmp_path, "[robot\nmodel = 1"))
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario(tmp_path / "absent.toml")
    with pytest.raises(ScenarioError, match=r"shipped scenarios: .*afma6-gaze-demo"):
        load_scenario("no-such-scenario")


def test_overrides(tmp_path: Path) -> None:
    sc = load_scenario(_write(tmp_path, GOOD))
    sc2 = apply_overrides(
        sc, ["control.lam=0.9", 'control.method="classical"', "simulation.noise_std=0.001"]
    )
    assert sc2.data["control"]["lam"] == 0.9 and sc2.method == "classical"
    assert sc.data["control"]["lam"] == 0.6  # the original is untouched
    exp = build(sc2)
    assert exp.options.lam == 0.9 and exp.options.noise_std == 0.001
    with pytest.raises(ScenarioError, match="key=value"):
        apply_overrides(sc, ["control.lam"])
    with pytest.raises(ScenarioError, match=r"control\.method"):
        apply_overrides(sc, ["control.method=nope"])


def test_start_pose_through_inverse_kinematics(tmp_path: Path) -> None:
    from redservo.robots import Afma6

    robot = Afma6()
    q_ref = robot.limits().center + np.array([0.1, -0.05, 0.02, 0.3, 0.1, -0.2])
    T = robot.fkine(q_ref)
    from redservo.spatial import matrix_to_rotvec

    text = GOOD.replace(
        "q0 = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0]",
        f"start_pose = {{ translation = {T[:3, 3].tolist()}, rotvec = {matrix_to_rotvec(T[:3, :3]).tolist()} }}\n"
        f"q_guess = {q_ref.tolist()}",
    )
    exp = build(load_scenario(_write(tmp_path, text)))
    np.testing.assert_allclose(exp.robot.fkine(exp.q0), T, atol=1e-8)


def test_documented_example_parses_and_runs() -> None:
    """docs/scenarios.md's fully commented example is a valid scenario."""
    import re

    text = (Path(__file__).resolve().parents[1] / "docs" / "scenarios.md").read_text()
    block = re.search(r"```toml\n(.*?)```", text, re.S)
    assert block is not None
    sc = parse_scenario(tomllib.loads(block.group(1)), "docs/scenarios.md")
    assert build(sc).run().outcome == "converged"


def test_hand_eye_error_is_applied_to_the_controllers_model(tmp_path: Path) -> None:
    """simulation.eMc_error: the controller uses eMc @ error, the true robot keeps eMc."""
    from redservo.spatial import make_transform

    sc = apply_overrides(
        load_scenario(_write(tmp_path, GOOD)),
        ["simulation.eMc_error={translation=[0.01, 0.0, 0.0], rotvec=[0.0, 0.05, 0.0]}"],
    )
    exp = build(sc)
    want = exp.robot.eMc @ make_transform(t=(0.01, 0.0, 0.0), rotvec=(0.0, 0.05, 0.0))
    assert exp.options.eMc_model is not None
    np.testing.assert_allclose(exp.options.eMc_model, want, atol=1e-12)
    assert not np.allclose(exp.robot.eMc, want)
