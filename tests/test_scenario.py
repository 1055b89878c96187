"""Scenario files: a schema validates them (one-line errors naming the file and the key), the
experiment is built through the registries, and every new key reaches the simulator."""

from __future__ import annotations

import inspect
import json
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from redservo import ScenarioError
from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario, parse_scenario, shipped_scenarios

ROOT = Path(__file__).resolve().parents[1]
BAD = Path(__file__).parent / "data" / "bad_scenarios"

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


def _data(**tables: dict[str, Any]) -> dict[str, Any]:
    data = tomllib.loads(GOOD)
    for name, table in tables.items():
        data.setdefault(name, {}).update(table)
    return data


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


def test_dt_and_lam_have_lower_bounds_a_robot_can_use() -> None:
    """dt = 1e-300 or lam = 1e-300 ran 600 motionless iterations; the bounds themselves (a
    10 kHz loop, a 1000 s time constant) are valid, and the reason is in the docs."""
    from redservo.schema.scenario import DT_MIN, LAM_MIN

    assert (DT_MIN, LAM_MIN) == (1e-4, 1e-3)
    data = tomllib.loads(GOOD)
    data["control"].update(dt=DT_MIN, lam=LAM_MIN)
    sc = parse_scenario(data, "my.toml")
    assert (sc.spec.control.dt, sc.spec.control.lam) == (DT_MIN, LAM_MIN)
    data["control"].pop("lam")
    data["control"]["gain"] = {"zero": 1e-300, "inf": 1e-300, "slope": 0.0}
    with pytest.raises(ScenarioError, match=r"key 'control\.gain\.zero': must be >= 0\.001"):
        parse_scenario(data, "my.toml")
    text = (ROOT / "docs" / "scenarios.md").read_text()
    assert "number, >= 0.0001, <= 10" in text and "number, >= 0.001, <= 1000" in text
    assert "10 kHz" in text and "1000 s" in text


@pytest.mark.parametrize(
    ("edit", "key", "hint"),
    [
        (lambda d: d["robot"].pop("model"), "robot.model", "missing"),
        (lambda d: d["robot"].__setitem__("model", "puma"), "robot.model", "afma6"),
        (lambda d: d["control"].__setitem__("method", "magic"), "control.method", "iterative"),
        (lambda d: d["control"].__setitem__("lam", "fast"), "control.lam", "expected a number"),
        (lambda d: d["control"].__setitem__("lam", float("inf")), "control.lam", "finite"),
        (lambda d: d["control"].__setitem__("dt", 0.0), "control.dt", ">= 0.0001"),
        (lambda d: d["control"].__setitem__("dt", 1e-300), "control.dt", ">= 0.0001"),
        (lambda d: d["control"].__setitem__("lam", 1e-300), "control.lam", ">= 0.001"),
        (lambda d: d["control"].__setitem__("lam", 9.99e-4), "control.lam", ">= 0.001"),
        (lambda d: d["features"][0].__setitem__("kind", "blob"), "features[0].kind", "cylinder"),
        (lambda d: d["features"][0].__setitem__("object", "ghost"), "features[0].object", "target"),
        (lambda d: d["robot"].__setitem__("qzero", [0.0]), "robot.qzero", "unknown key"),
        (lambda d: d["objects"][0].__setitem__("kind", "cube"), "objects[0].kind", "sphere"),
        (
            lambda d: d["control"].__setitem__("options", {"alfa": 1.0}),
            "control.options.alfa",
            "options are",
        ),
        (
            lambda d: d["simulation"].__setitem__("max_iterations", 10**8),
            "simulation.max_iterations",
            "<= 10000000",
        ),
        (lambda d: d["task"].__setitem__("desired", [0.0]), "task.desired", "expected 2 values"),
    ],
)
def test_validation_errors_name_file_key_and_allowed(edit: Any, key: str, hint: str) -> None:
    data = tomllib.loads(GOOD)
    edit(data)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, "my.toml")
    msg = str(info.value)
    assert msg.startswith(f"my.toml: key '{key}'"), msg
    assert hint in msg and "\n" not in msg, msg
    assert info.value.argument == key


@pytest.mark.parametrize(
    ("edit", "key", "hint"),
    [
        (
            lambda d: d["robot"].__setitem__("q0", [9.0, 0, 0, 0, 1, 0]),
            "robot.q0[0]",
            "outside the joint limits",
        ),
        (lambda d: d["robot"].__setitem__("q0", [0.0, 0.0]), "robot.q0", "6 values"),
        (
            lambda d: d["objects"][0].__setitem__("pose_in_camera", {"translation": [0, 0, -1]}),
            "objects[0]",
            "behind",
        ),
        (
            lambda d: d["objects"][0].__setitem__("pose_in_camera", {"translation": [2, 0, 0.8]}),
            "objects[0]",
            "outside the image",
        ),
    ],
)
def test_geometry_is_checked_when_building_not_when_validating(
    edit: Any, key: str, hint: str
) -> None:
    data = tomllib.loads(GOOD)
    edit(data)
    sc = parse_scenario(data, "my.toml")  # valid as a file
    with pytest.raises(ScenarioError) as info:
        build(sc)
    assert str(info.value).startswith(f"my.toml: key '{key}'") and hint in str(info.value)


def test_validating_does_not_build_or_import_the_simulator() -> None:
    """The scenario ⇄ experiment import cycle is gone: validation imports neither."""
    code = (
        "import sys; from redservo.scenario import load_scenario; load_scenario('cm01-gaze'); "
        "print([m for m in ('redservo.experiment.build', 'redservo.simulation') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def _corpus() -> list[tuple[str, dict[str, str]]]:
    expected = json.loads((BAD / "expected.json").read_text())
    files = sorted(p.name for p in BAD.glob("*.toml"))
    assert sorted(expected) == files, "every broken file has its expected key in expected.json"
    return sorted(expected.items())


def test_the_corpus_covers_every_kind_of_breakage() -> None:
    names = [n for n, _ in _corpus()]
    assert len(names) >= 40
    for prefix in ("syntax", "missing", "type", "typo", "absurd", "geometry", "empty", "inverted"):
        assert any(n.startswith(prefix) for n in names), prefix
    assert {"binary_garbage.toml", "latin1_encoding.toml"} <= set(names)
    assert sum("did you mean" in c["expect"] for _, c in _corpus()) >= 4


@pytest.mark.parametrize(("name", "case"), _corpus(), ids=[n for n, _ in _corpus()])
def test_every_broken_file_is_one_line_naming_file_and_key(
    name: str, case: dict[str, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from redservo.cli.entry import main

    path = BAD / name
    assert main(["run", str(path), "-q", "--out", str(tmp_path / "o")]) == 2, case["what"]
    out, err = capsys.readouterr()
    assert out == ""
    assert err.endswith("\n") and err.count("\n") == 1, err
    assert err.startswith(f"redservo: error: {path}: "), err
    assert case["expect"] in err, (case, err)
    assert "Traceback" not in err
    assert not (tmp_path / "o").exists()  # nothing ran


def test_malformed_toml_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match=r"not valid TOML.*line 2"):
        load_scenario(_write(tmp_path, "[robot]\nmodel = \n"))
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario(tmp_path / "absent.toml")
    (tmp_path / "dir.toml").mkdir()
    with pytest.raises(ScenarioError, match="is a directory"):
        load_scenario(tmp_path / "dir.toml")
    with pytest.raises(ScenarioError, match=r"shipped scenarios: .*afma6-gaze-demo"):
        load_scenario("no-such-scenario")
    with pytest.raises(ScenarioError, match="did you mean 'cm01-gaze'"):
        load_scenario("cm01-gaz")


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
    with pytest.raises(
        ScenarioError, match=r"key 'simulation.max_iterations': expected an integer"
    ):
        apply_overrides(sc, ["simulation.max_iterations=1e12"])
    with pytest.raises(ScenarioError, match="empty key segment"):
        apply_overrides(sc, ["control..lam=1"])
    unnamed = load_scenario(_write(tmp_path, GOOD.replace('name = "mine"', "")))
    assert apply_overrides(unnamed, ["control.lam=0.5"]).name == unnamed.name == "my"


def test_start_pose_through_inverse_kinematics(tmp_path: Path) -> None:
    from redservo.robots import Afma6
    from redservo.spatial import matrix_to_rotvec

    robot = Afma6()
    q_ref = robot.limits().center + np.array([0.1, -0.05, 0.02, 0.3, 0.1, -0.2])
    T = robot.fkine(q_ref)
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

    text = (ROOT / "docs" / "scenarios.md").read_text()
    block = re.search(r"```toml\n(.*?)```", text, re.S)
    assert block is not None
    sc = parse_scenario(tomllib.loads(block.group(1)), "docs/scenarios.md")
    assert build(sc).run().outcome == "converged"


def test_reference_in_the_docs_is_generated_from_the_schema() -> None:
    from redservo.schema.docs import main

    assert main(["--check", str(ROOT)]) == 0, "run: python -m redservo.schema.docs"


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


# --------------------------------------------------------------------------- registries


def test_kinds_match_the_registries() -> None:
    """A kind is its runtime class plus one spec: the specs cover exactly the registries."""
    from redservo.features import FEATURES
    from redservo.schema.features import FEATURE_KINDS
    from redservo.schema.scene import OBJECT_KINDS

    assert set(FEATURE_KINDS) == set(FEATURES)
    assert set(OBJECT_KINDS) == {"points", "sphere", "cylinder", "line", "tag"}


@pytest.mark.parametrize(
    ("feature", "obj"),
    [
        ({"kind": "point"}, {"kind": "points", "points": [[0, 0, 0], [0.05, 0, 0]]}),
        ({"kind": "line"}, {"kind": "line", "direction": [0, 1, 0]}),
        ({"kind": "cylinder"}, {"kind": "cylinder", "radius": 0.05}),
        ({"kind": "sphere", "variant": "exact"}, {"kind": "sphere", "radius": 0.05}),
        ({"kind": "sphere", "variant": "moments"}, {"kind": "sphere", "radius": 0.05}),
        (
            {"kind": "moments"},
            {
                "kind": "points",
                "points": [[-0.05, -0.05, 0], [0.05, -0.04, 0], [0.06, 0.05, 0], [-0.04, 0.07, 0]],
            },
        ),
    ],
)
def test_static_feature_sizes_match_the_built_features(
    feature: dict[str, Any], obj: dict[str, Any]
) -> None:
    """The schema checks components and task.desired with sizes it knows without building."""
    data = tomllib.loads(GOOD)
    data["objects"][0] = {
        "name": "target",
        "pose_in_camera": {"translation": [0.0, 0.0, 0.8]},
        **obj,
    }
    data["features"][0] = {"object": "target", **feature}
    data["task"] = {"desired_pose": {"translation": [0.0, 0.0, 0.7]}}
    sc = parse_scenario(data, "x.toml")
    spec = sc.spec.features[0]
    exp = build(sc)
    assert exp.task.k == spec.size(sc.spec.objects[0]) * spec.count(sc.spec.objects[0])


# --------------------------------------------------------------------------- new keys


def test_robot_rate_limits_and_margin_reach_the_limits() -> None:
    sc = parse_scenario(_data(robot={"qdot_max": 0.3, "qddot_max": [2.0] * 6, "margin": 0.02}))
    exp = build(sc)
    np.testing.assert_allclose(exp.limits.qdot_max, 0.3)
    np.testing.assert_allclose(exp.limits.qddot_max, 2.0)
    np.testing.assert_allclose(exp.limits.margin_fraction, 0.02)
    default = build(parse_scenario(_data()))
    np.testing.assert_allclose(default.limits.margin_fraction, 0.01)  # the documented default
    with pytest.raises(ScenarioError, match=r"key 'robot.qdot_max': expected 6 values"):
        build(parse_scenario(_data(robot={"qdot_max": [1.0, 1.0]})))


def test_control_safety_and_adaptive_gain_reach_the_law_and_the_options() -> None:
    from redservo import AdaptiveGain

    data = _data(simulation={"min_margin": 0.05})
    data["control"] = {
        "method": "gpm",
        "shield": False,
        "robust": False,
        "scaling": "secondary-first",
        "gain": {"zero": 2.0, "inf": 0.5, "slope": 20.0},
    }
    sc = parse_scenario(data)
    exp = build(sc)
    assert (exp.law.shield, exp.law.robust, exp.law.scaling) == (False, False, "secondary-first")
    assert exp.options.lam == AdaptiveGain(2.0, 0.5, 20.0)
    assert exp.options.min_margin == 0.05
    # Another method keeps the scenario's safety settings unless the caller sets them.
    res = exp.run(method="classical", max_iterations=2)
    assert res.summary.min_margin_required == 0.05
    law_default = build(parse_scenario(_data())).law
    assert (law_default.shield, law_default.robust, law_default.scaling) == (True, True, "uniform")
    with pytest.raises(ScenarioError, match=r"key 'control.gain.inf'"):
        data["control"]["gain"] = {"zero": 1.0, "inf": 2.0, "slope": 0.0}
        parse_scenario(data)


def test_actuator_table_builds_the_actuator_model() -> None:
    from redservo.hardware.actuators import ACTUATOR_KEYS, ActuatorModel
    from redservo.schema.scenario import ActuatorsSpec

    keys = {ActuatorsSpec.MODEL_KEYS.get(k, k) for k in ActuatorsSpec.model_fields}
    assert keys == set(ACTUATOR_KEYS)
    sc = parse_scenario(
        _data(actuators={"tau": 0.02, "delay_steps": 1, "encoder_noise_std": [1e-5] * 6, "seed": 3})
    )
    exp = build(sc)
    assert isinstance(exp.actuator, ActuatorModel)
    assert exp.run(max_iterations=5).outcome in ("max_iterations", "converged")
    with pytest.raises(ScenarioError, match=r"key 'actuators.delay_steps'"):
        parse_scenario(_data(actuators={"delay_steps": -1}))


def test_image_sensor_keys_match_the_sensor() -> None:
    from redservo.schema.scenario import SensorSpec

    pytest.importorskip("cv2", reason="the image sensor needs OpenCV (redservo[vision])")
    from redservo.experiment.sensor import TIMING_KEYS
    from redservo.vision import DEPTH_POLICIES, ImageSensor

    params = inspect.signature(ImageSensor.__init__).parameters
    # The camera's timing keys are the TimedSensor's (redservo.sensors.timing), not the image's.
    fields = {k: v for k, v in SensorSpec.model_fields.items() if k not in TIMING_KEYS}
    for name, field in fields.items():
        if name != "kind":
            assert field.default == params[name].default, name  # same defaults, one place each
    assert set(fields) - {"kind"} == set(params) - {"self", "camera", "options"}
    assert set(SensorSpec.model_fields["depth"].annotation.__args__) == set(DEPTH_POLICIES)  # type: ignore[union-attr]
    with pytest.raises(ScenarioError, match=r"key 'sensor.depth': .*needs task.desired_pose"):
        parse_scenario(_data(sensor={"kind": "image"}))
    sensor = {"kind": "image", "noise_px": 1.0, "seed": 5, "depth": "true"}
    exp = build(parse_scenario(_data(sensor=sensor)))
    assert isinstance(exp.sensor, ImageSensor) and exp.sensor.renderer.options.noise_px == 1.0
    hidden = _data(sensor=sensor)
    hidden["camera"] = {"u0": 700.0}  # the principal point far off: the dot is not in the image
    hidden["simulation"]["check_image"] = False
    with pytest.raises(ScenarioError, match=r"key 'sensor': the image sensor does not see"):
        build(parse_scenario(hidden))


def test_urdf_robot_from_a_shipped_file_and_a_relative_path(tmp_path: Path) -> None:
    pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio (redservo[urdf])")
    from redservo.robots import URDFRobot, shipped_urdf

    base = load_scenario("panda-4points").data if "panda-4points" in shipped_scenarios() else None
    if base is None:
        pytest.skip("no shipped Panda scenario")
    data = json.loads(json.dumps(base))
    data["robot"].pop("model")
    data["robot"].pop("options", None)
    data["robot"]["urdf"] = "panda"
    exp = build(parse_scenario(data, "p.toml"))
    assert isinstance(exp.robot, URDFRobot) and exp.robot.n == 7
    (tmp_path / "arm.urdf").write_text(shipped_urdf("panda").read_text())
    data["robot"]["urdf"] = "arm.urdf"
    sc = parse_scenario(data, "p.toml", base_dir=tmp_path)
    assert sc.data["robot"]["urdf"] == str((tmp_path / "arm.urdf").resolve())
    assert isinstance(build(sc).robot, URDFRobot)
    data["robot"]["urdf"] = "pandda"
    with pytest.raises(ScenarioError, match="did you mean 'panda'"):
        parse_scenario(data, "p.toml")


# -- issue 33: shipped:NAME as input, a folder or file named like a shipped scenario --------


def test_the_shipped_prefix_messages_print_is_accepted_as_input() -> None:
    from redservo.campaign import load_campaign

    sc = load_scenario("shipped:cm01-gaze")
    assert sc.source == "shipped:cm01-gaze" and sc.data == load_scenario("cm01-gaze").data
    for name in ("shipped:campaigns/cm01-gaze", "shipped:cm01-gaze"):
        assert load_campaign(name).source == "shipped:campaigns/cm01-gaze"
    with pytest.raises(
        ScenarioError, match=r"unknown scenario 'shipped:cm01-gaz'.*did you mean 'cm01-gaze'"
    ):
        load_scenario("shipped:cm01-gaz")


def test_a_folder_named_like_a_shipped_scenario_does_not_shadow_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cm01-gaze").mkdir()  # e.g. redservo run cm01-gaze --out cm01-gaze
    assert load_scenario("cm01-gaze").source == "shipped:cm01-gaze"
    assert capsys.readouterr().err == (
        "note: 'cm01-gaze' is a folder here and a shipped scenario: using the shipped scenario "
        "(shipped:cm01-gaze); for a file in the folder give its path, e.g. cm01-gaze/NAME.toml\n"
    )


def test_a_file_named_like_a_shipped_scenario_is_ambiguous(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cm01-gaze").write_text(
        (ROOT / "src/redservo/scenarios/afma6-gaze-demo.toml").read_text()
    )
    with pytest.raises(ScenarioError) as err:
        load_scenario("cm01-gaze")
    assert str(err.value) == (
        "'cm01-gaze' is both a file here and a shipped scenario: give ./cm01-gaze for the file "
        "or shipped:cm01-gaze for the shipped scenario"
    )
    assert load_scenario("./cm01-gaze").source == "cm01-gaze"  # the file
    assert load_scenario("shipped:cm01-gaze").source == "shipped:cm01-gaze"
