"""One declaration per robot kind (redservo.robots.pack.RobotKind): a robot packs itself, the
kind codes and the compiled kinematics dispatch come from the declared kinds
(redservo.kernels.robot_kinds, redservo.kernels.robot), and a new kind is one file
(examples/scara_robot.py), compiled through ``run`` and a campaign."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from redservo.errors import ConfigurationError
from redservo.robots import Afma6, Humanoid9, Panda, make_robot, register_robot
from redservo.robots.pack import AFMA6, CHAIN, DH, RobotKind
from tests.examples_cache import run_example

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "scara_robot.py"


def _urdf() -> object:
    from redservo.robots.urdf import URDFRobot, shipped_urdf

    return URDFRobot(shipped_urdf("ur5e"), camera_link="camera_link")


def test_the_shipped_robots_pack_themselves_and_the_dispatch_gives_their_numbers() -> None:
    from redservo.kernels import robot_kinds
    from redservo.kernels.robot import SOURCE, robot_kinematics

    assert [name for name, _ in robot_kinds.kinds()[:3]] == ["afma6", "dh", "chain"]
    assert "if kind == 0:" in SOURCE and "if kind == 1:" in SOURCE
    rng = np.random.default_rng(3)
    for robot, code in ((Afma6(), AFMA6), (Panda(), DH), (Humanoid9(), DH), (_urdf(), CHAIN)):
        pack = robot.kernel_pack()  # type: ignore[attr-defined]
        assert pack is not None and pack[0] == code and len(pack) == 6
        for _ in range(3):
            q = robot.q_min + (robot.q_max - robot.q_min) * rng.random(robot.n)  # type: ignore[attr-defined]
            bMc, J = robot_kinematics(np.ascontiguousarray(q), pack)
            b2, J2 = robot.kinematics(q)  # type: ignore[attr-defined]
            np.testing.assert_array_equal(bMc, b2)
            np.testing.assert_array_equal(J, J2)


def test_a_bad_kind_declaration_or_pack_is_one_clear_error() -> None:
    with pytest.raises(ConfigurationError, match="unknown shipped kind 'scara'; shipped: afma6"):
        RobotKind("scara")
    with pytest.raises(ConfigurationError, match="kernel 'nowhere' is not 'module:function'"):
        RobotKind("x", "nowhere")
    with pytest.raises(ConfigurationError, match=r"no kernel 'redservo\.kernels\.chain:nothing'"):
        RobotKind("x", "redservo.kernels.chain:nothing")
    with pytest.raises(ConfigurationError, match="'afma6' is already declared with kernel"):
        RobotKind("afma6", "redservo.kernels.chain:chain_robot")
    with pytest.raises(ConfigurationError, match="scalars has 2 dimension"):
        RobotKind("afma6").pack(np.eye(4), np.eye(6), scalars=np.zeros((1, 2)))


def test_a_kind_declared_after_the_dispatch_was_generated_runs_on_the_object_path() -> None:
    import redservo.kernels.robot  # noqa: F401 - generates (and freezes) the dispatch

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        late = RobotKind("late_kind_for_the_test", "redservo.kernels.chain:chain_robot")
    assert "declared after the compiled kinematics were generated" in str(caught[0].message)
    assert late.code is None and late.pack(np.eye(4), np.eye(6)) is None


def test_register_robot_adds_a_model_name_and_refuses_bad_names() -> None:
    from redservo.robots import ROBOTS

    with pytest.raises(ConfigurationError, match="name 'Bad Name': allowed are lower-case"):
        register_robot("Bad Name", Afma6)
    with pytest.raises(ConfigurationError, match="robot 'afma6' is already registered"):
        register_robot("afma6", Panda)
    code = (
        "import redservo, redservo.robots as R\n"
        "R.register_robot('afma6b', R.Afma6)\n"
        "sc = redservo.load_scenario('afma6-gaze-demo', {'robot.model': 'afma6b'})\n"
        "print(sc.spec.robot.model, R.make_robot('afma6b').n, 'afma6b' in R.ROBOTS)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["afma6b", "6", "True"]
    assert "afma6b" not in ROBOTS and make_robot("afma6").n == 6


def test_the_example_kind_matches_its_finite_differences_on_the_reference_path() -> None:
    """The SCARA's kernel (plain Python): ``J`` is the derivative of the camera pose, and the
    compiled engine's dispatch (its code 3) gives the object's numbers."""
    code = (
        "import sys, numpy as np\n"
        f"sys.path.insert(0, {str(EXAMPLE.parent)!r})\n"
        "import scara_robot as S\n"
        "from redservo.spatial import inverse, log_transform\n"
        "from redservo.kernels.robot import robot_kinematics\n"
        "r, q, h = S.Scara(), np.array([0.3, 1.2, 0.1, 0.4]), 1e-6\n"
        "bMc, J = r.kinematics(q)\n"
        "for i in range(4):\n"
        "    d = np.zeros(4); d[i] = h\n"
        "    tw = (log_transform(inverse(bMc) @ r.fkine(q + d))\n"
        "          - log_transform(inverse(bMc) @ r.fkine(q - d))) / (2 * h)\n"
        "    assert np.allclose(tw, J[:, i], atol=1e-7), (i, tw, J[:, i])\n"
        "pack = r.kernel_pack()\n"
        "b2, J2 = robot_kinematics(q, pack)\n"
        "assert np.array_equal(b2, bMc) and np.array_equal(J2, J)\n"
        "print('ok', pack[0])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "PYTHONPATH": str(ROOT / "src"), "REDSERVO_NO_NUMBA": "1"},
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["ok", "3"]


@pytest.mark.xdist_group("examples")  # one compiled chain (tests/examples_cache.py)
def test_a_new_robot_kind_is_one_file_and_runs_compiled() -> None:
    """The example's SCARA (one file: kernel, declaration, pack, one registry line) gets the
    next kind code and runs on the compiled step through ``run`` and on the campaign's
    compiled loop."""
    from redservo.kernels import compiled

    if not compiled():
        pytest.skip("numba is not installed")
    # its own numba cache, shared with the law example (tests/examples_cache.py)
    done = run_example("scara_robot")
    assert done.returncode == 0, done.stderr
    text = done.stdout
    assert "kind: scara code 3" in text
    assert "engine compiled" in text
    assert "campaign: classical" in text and "campaign: gpm" in text
    assert "Engine: 4 run(s) computed by this call on the compiled loop." in text
    assert "object path" not in text
