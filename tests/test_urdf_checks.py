"""URDF limits are never silently lost (issue 17): rates, geometry bounds, urdfdom's stderr."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pinocchio", reason="URDFRobot needs the extra redservo[urdf] (Pinocchio)")

import redservo.robots.urdf as urdf_module
from redservo.errors import ConfigurationError, UnknownNameError
from redservo.robots import URDFRobot, shipped_urdf
from redservo.robots.panda import PANDA_QDDOT_MAX, PANDA_QDOT_MAX
from redservo.robots.urdf_parse import pinocchio_xml, read_urdf
from redservo.robots.urdf_stderr import captured_stderr, condense
from tests.test_urdf import TINY_URDF

PANDA = shipped_urdf("panda").read_text()
JOINT2_LIMIT = '<limit lower="-1.7628" upper="1.7628" effort="87" velocity="2.175"/>'


def _panda_with(tmp_path: Path, old: str, new: str, count: int = 1) -> Path:
    """A copy of the shipped Panda with the first ``count`` ``old`` replaced by ``new``."""
    assert old in PANDA
    path = tmp_path / "arm.urdf"
    path.write_text(PANDA.replace(old, new, count))
    return path


def _tiny_with(tmp_path: Path, old: str, new: str) -> Path:
    assert old in TINY_URDF
    path = tmp_path / "tiny.urdf"
    path.write_text(TINY_URDF.replace(old, new, 1))
    return path


def _arm(path: Path, **options: Any) -> URDFRobot:
    return URDFRobot(path, camera_link="camera_link", **options)


# -- velocity limits ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "velocity", ['velocity="0"', 'velocity="-2"', 'velocity="nan"', 'velocity="inf"',
                 'velocity="abc"', 'velocity="1e308"', 'velocity="100.5"', ""],
)  # fmt: skip
def test_a_bad_file_velocity_is_an_error_naming_the_file_and_joint(
    tmp_path: Path, velocity: str
) -> None:
    path = _panda_with(tmp_path, JOINT2_LIMIT, JOINT2_LIMIT.replace('velocity="2.175"', velocity))
    with pytest.raises(ConfigurationError) as info:
        _arm(path)
    text = str(info.value)
    assert str(path) in text and "'panda_joint2'" in text, text
    assert "(0, 100] rad/s" in text and "qdot_max" in text, text
    assert info.value.argument == "path"


def test_the_callers_qdot_max_replaces_a_bad_file_velocity(tmp_path: Path) -> None:
    for bad in ('velocity="0"', 'velocity="abc"', ""):
        path = _panda_with(tmp_path, JOINT2_LIMIT, JOINT2_LIMIT.replace('velocity="2.175"', bad))
        # For that joint only: the other joints keep the file's values.
        robot = _arm(path, qdot_max={"panda_joint2": 1.5})
        expected = np.array(PANDA_QDOT_MAX)
        expected[1] = 1.5
        assert np.array_equal(robot.qdot_max, expected)  # type: ignore[arg-type]
        # For every joint: a scalar or one value per joint.
        assert np.array_equal(_arm(path, qdot_max=1.0).qdot_max, np.ones(7))  # type: ignore[arg-type]
        per_joint = np.linspace(1.0, 2.0, 7)
        assert np.array_equal(_arm(path, qdot_max=per_joint).qdot_max, per_joint)  # type: ignore[arg-type]


def test_only_the_servoed_joints_need_a_velocity(tmp_path: Path) -> None:
    path = _panda_with(tmp_path, 'velocity="2.175"', 'velocity="0"')  # panda_joint1
    wrist = _arm(path, joints=["panda_joint5", "panda_joint6", "panda_joint7"])
    assert np.array_equal(wrist.qdot_max, PANDA_QDOT_MAX[4:])  # type: ignore[arg-type]


def test_prismatic_and_continuous_joints_need_a_velocity_too(tmp_path: Path) -> None:
    slide = _tiny_with(tmp_path, 'velocity="0.25"', 'velocity="11"')
    with pytest.raises(ConfigurationError, match=r"'slide' \(prismatic\).*\(0, 10\] m/s"):
        URDFRobot(slide, camera_link="cam")
    assert URDFRobot(slide, camera_link="cam", qdot_max={"slide": 0.5}).qdot_max[0] == 0.5  # type: ignore[index]
    table = _tiny_with(tmp_path, '<limit effort="10" velocity="2.0"/>', "")
    with pytest.raises(ConfigurationError, match=r"'turntable'.*<limit velocity>") as info:
        URDFRobot(table, camera_link="cam")
    assert str(table) in str(info.value)
    robot = URDFRobot(table, camera_link="cam", qdot_max={"turntable": 3.0})
    assert np.array_equal(robot.qdot_max, [0.25, 3.0, 1.5])  # type: ignore[arg-type]


def test_a_joint_mapping_names_servoed_joints_and_positive_values(tmp_path: Path) -> None:
    path = shipped_urdf("panda")
    with pytest.raises(UnknownNameError, match=r"'elbow'.*panda_joint1"):
        _arm(path, qdot_max={"elbow": 1.0})
    for bad in (0.0, -1.0, float("nan"), "fast", True):
        with pytest.raises(ConfigurationError, match=r"qddot_max\['panda_joint3'\]"):
            _arm(path, qddot_max={"panda_joint3": bad})


# -- acceleration limits --------------------------------------------------------------------------


def test_accelerations_from_the_file_the_caller_or_none(tmp_path: Path) -> None:
    shipped = _arm(shipped_urdf("panda"))
    assert np.array_equal(shipped.qddot_max, PANDA_QDDOT_MAX)  # type: ignore[arg-type]
    over = _arm(shipped_urdf("panda"), qddot_max={"panda_joint7": 5.0})
    assert np.array_equal(over.qddot_max, (*PANDA_QDDOT_MAX[:6], 5.0))  # type: ignore[arg-type]
    # A user's file without the extension: no acceleration limits unless given.
    plain = tmp_path / "plain.urdf"
    plain.write_text(re.sub(r"\s*<redservo:limit [^>]*/>", "", PANDA))
    assert _arm(plain).qddot_max is None
    assert np.array_equal(_arm(plain, qddot_max=4.0).qddot_max, np.full(7, 4.0))  # type: ignore[arg-type]
    # ... a partial set is an error naming the joints without one ...
    partial = _panda_with(tmp_path, '<redservo:limit acceleration="7.5"/>', "")
    with pytest.raises(ConfigurationError, match=r"'panda_joint2'.*redservo:limit acceleration"):
        _arm(partial)
    assert _arm(partial, qddot_max={"panda_joint2": 7.5}).qddot_max[1] == 7.5  # type: ignore[index]
    # ... and so is a bad value.
    for bad in ("0", "-3", "nan", "2000"):
        path = _panda_with(tmp_path, 'acceleration="7.5"', f'acceleration="{bad}"')
        with pytest.raises(ConfigurationError, match=r"'panda_joint2'.*\(0, 1000\] rad/s²"):
            _arm(path)


# -- origins, axes, position limits ---------------------------------------------------------------

J1_ORIGIN = '<origin xyz="0 0 0.333" rpy="0 0 0"/>'


@pytest.mark.parametrize(
    ("old", "new", "needle"),
    [
        (J1_ORIGIN, '<origin xyz="0 0 1e308" rpy="0 0 0"/>', r"origin xyz.*\[-100, 100\] m"),
        (J1_ORIGIN, '<origin xyz="0 0 101" rpy="0 0 0"/>', r"\[-100, 100\] m"),
        (J1_ORIGIN, '<origin xyz="0 0 nan" rpy="0 0 0"/>', "three finite numbers"),
        (J1_ORIGIN, '<origin xyz="0 0.333" rpy="0 0 0"/>', "three finite numbers"),
        (J1_ORIGIN, '<origin xyz="0 0 0.333" rpy="0 0 90"/>', r"\[-7, 7\] rad.*degrees"),
        ('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>', "no direction"),
        ('<axis xyz="0 0 1"/>', '<axis xyz="0 0 inf"/>', "three finite numbers"),
        ('lower="-2.8973" upper="2.8973"', 'lower="-1e15" upper="1e15"', r"\[-100, 100\]"),
    ],
)
def test_bad_geometry_is_an_error_naming_the_file_and_joint(
    tmp_path: Path, old: str, new: str, needle: str
) -> None:
    path = _panda_with(tmp_path, old, new)
    with pytest.raises(ConfigurationError, match=needle) as info:
        _arm(path)
    assert str(path) in str(info.value) and "'panda_joint1'" in str(info.value)


def test_prismatic_limits_are_bounded(tmp_path: Path) -> None:
    path = _tiny_with(tmp_path, 'lower="-0.3" upper="0.5"', 'lower="-1e15" upper="1e15"')
    with pytest.raises(ConfigurationError, match=r"'slide'.*lower='-1e15'.*\[-100, 100\]"):
        URDFRobot(path, camera_link="cam")


def test_an_axis_is_normalised(tmp_path: Path) -> None:
    long_axis = _panda_with(tmp_path, '<axis xyz="0 0 1"/>', '<axis xyz="0 0 2.5"/>', count=7)
    robot, ref = _arm(long_axis), _arm(shipped_urdf("panda"))
    q = np.array([0.3, -0.5, 0.2, -2.0, 0.4, 1.5, 0.7])
    np.testing.assert_allclose(robot.fkine(q), ref.fkine(q), atol=1e-12)
    np.testing.assert_allclose(robot.jacobian(q), ref.jacobian(q), atol=1e-12)
    tree = read_urdf(long_axis)
    assert tree.joints["panda_joint1"].axis == (0.0, 0.0, 1.0)
    assert 'xyz="0.0 0.0 1.0"' in pinocchio_xml(tree) and "redservo" not in pinocchio_xml(tree)


# -- urdfdom's own output -------------------------------------------------------------------------


def test_urdfdom_output_is_folded_into_one_error(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    bad = '<axis xyz="0 0 1"/><dynamics damping="abc"/>'
    path = _panda_with(tmp_path, '<axis xyz="0 0 1"/>', bad)
    with pytest.raises(ConfigurationError) as info:
        _arm(path)
    text = str(info.value)
    assert str(path) in text and "Pinocchio cannot build a model" in text, text
    assert "damping value (abc) is not a valid float" in text and "[panda_joint1]" in text, text
    assert ".cpp" not in text and "\n" not in text
    assert capfd.readouterr() == ("", "")  # nothing raw reached stdout or stderr


def test_loading_a_good_file_prints_nothing(capfd: pytest.CaptureFixture[str]) -> None:
    _arm(shipped_urdf("panda"))
    URDFRobot(shipped_urdf("ur5e"), camera_link="camera_link")
    assert capfd.readouterr() == ("", "")


def test_a_parser_complaint_on_a_model_that_loads_is_one_warning(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    # Pinocchio builds the kinematics although urdfdom rejects a <visual> (which it does not use).
    path = _panda_with(tmp_path, '<box size="0.09 0.025 0.025"/>', '<box size="0.09 abc"/>')
    with pytest.warns(UserWarning) as record:
        robot = _arm(path)
    assert robot.n == 7 and len(record) == 1
    message = str(record[0].message)
    assert str(path) in message and "Unable to parse component [abc]" in message
    assert "Link [camera_link]" in message and ".cpp" not in message
    assert record[0].filename == __file__  # points at the caller
    assert capfd.readouterr() == ("", "")


def test_other_output_during_a_load_is_not_lost(
    monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    real = urdf_module._pinocchio()

    class Chatty:
        def __getattr__(self, name: str) -> Any:
            return getattr(real, name)

        def buildModelFromXML(self, xml: str) -> Any:
            os.write(2, b"a note on fd 2\n")
            return real.buildModelFromXML(xml)

    monkeypatch.setattr(urdf_module, "_PIN", Chatty())
    with pytest.warns(UserWarning, match="a note on fd 2"):
        URDFRobot(shipped_urdf("panda"), camera_link="camera_link")
    assert capfd.readouterr().err == ""


def test_captured_stderr_and_condense(capfd: pytest.CaptureFixture[str]) -> None:
    with captured_stderr() as printed:
        os.write(2, b"\x1b[31mError:   joint [j]: limit has no velocity\n")
        os.write(2, b"         at line 205 in /x/urdf_parser/src/joint.cpp\n\x1b[0m")
        os.write(2, b"Error:   joint xml is not initialized correctly\n")
        assert printed == []
    os.write(2, b"after\n")
    assert capfd.readouterr().err == "after\n"
    assert condense(printed[0]) == (
        "joint [j]: limit has no velocity; joint xml is not initialized correctly"
    )
    assert condense("x" * 1000, limit=20) == "x" * 17 + "..."
