"""``redservo servo`` and ``redservo sim-arm`` over real DDS on the loopback (issue 31): the
hardware file's errors, panda-4points end to end against the rehearsal arm in another
process, killing either side, and the dry run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("cyclonedds")
pytest.importorskip("mujoco")

from redservo.cli.entry import main
from redservo.ros2.messages import Float64MultiArray
from redservo.ros2.transport import Ros2Node

ROOT = Path(__file__).resolve().parents[1]
DOMAIN = 1 + os.getpid() % 19  # 1-19: no other ros2 test file uses it
# Topics of this test process only: two test runs on one machine may draw the same domain
# (a run's arm then counted the other run's commands: "a dry run sends nothing" saw 2).
JOINT_STATES = f"/servo_{os.getpid()}/joint_states"
COMMAND = f"/servo_{os.getpid()}/commands"
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
CLI = [sys.executable, "-c", "import sys; from redservo.cli.entry import main; sys.exit(main())"]


def hardware(tmp_path: Path, text: str = "", name: str = "hw.toml") -> Path:
    f = tmp_path / name
    f.write_text(
        f'[robot]\ndomain_id = {DOMAIN}\nwait = 20.0\njoint_states = "{JOINT_STATES}"\n'
        f'command = "{COMMAND}"\n{text}'
    )
    return f


@pytest.mark.parametrize(
    ("text", "key", "what"),
    [
        ('driver = "ur_rtde"', "robot.driver", "must be one of ['ros2', 'mujoco']"),
        ("speed = 1", "robot.speed", "unknown key"),
        ('joints = ["a", "b", "a"]', "robot.joints", "['a'] more than once"),
        ('command = "/velocity controller/commands"', "robot.command", "fully qualified"),
        ('command = "forward/commands"', "robot.command", "fully qualified"),
        ("domain_id = 300", "robot.domain_id", "0-232"),
        ('[camera]\ndriver = "webcam"', "camera.driver", "must be one of"),
        ('[robot]\ndriver = "mujoco"\n[camera]\ndriver = "ros2"', "camera.driver", "needs"),
        ('[camera]\nimage = "camera/image"', "camera.image", "fully qualified"),
        ("[loop]\nwatchdog_timeout = -1", "loop.watchdog_timeout", "> 0"),
        ("[loop]\nrealtime_priority = 100", "loop.realtime_priority", "integer 0-99"),
        ("[loop]\nspin = -0.001", "loop.spin", ">= 0"),
        ("[arm]\nx = 1", "arm", "unknown table"),
    ],
)
def test_hardware_file_errors_are_one_line_naming_the_key(
    tmp_path: Path, capsys: Any, text: str, key: str, what: str
) -> None:
    f = tmp_path / "hw.toml"
    f.write_text(text if text.startswith("[") else f"[robot]\n{text}\n")
    assert main(["servo", "panda-4points", "--hardware", str(f), "--yes"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert f"key '{key}'" in err and what in err, err


def test_missing_joint_names_are_refused_before_anything_is_sent(
    tmp_path: Path, capsys: Any
) -> None:
    f = hardware(tmp_path, 'joints = ["j1", "j2"]\n')
    assert main(["servo", "panda-4points", "--hardware", str(f), "--yes"]) == 2
    assert (
        "key 'robot.joints': names 2 joints; the scenario's panda has 7" in capsys.readouterr().err
    )


def test_servo_refuses_to_start_when_nobody_reads_the_commands(tmp_path: Path, capsys: Any) -> None:
    names = ",".join(f"joint{i}" for i in range(1, 8))
    out = tmp_path / "peer.json"
    peer = [sys.executable, str(ROOT / "tests" / "ros2_peer.py"), str(DOMAIN), str(out)]
    proc = subprocess.Popen([*peer, "--duration", "30", "--names", names, "--no-commands"], env=ENV)
    f = tmp_path / "hw.toml"
    joints = [f"joint{i}" for i in range(1, 8)]
    topic = f"/unread_{os.getpid()}/commands"  # read by no process, whoever shares the domain
    f.write_text(
        f"[robot]\ndomain_id = {DOMAIN}\nwait = 20.0\ncommand_wait = 0.3\njoints = {joints}\n"
        f'command = "{topic}"\n'
    )
    try:
        code = main(["servo", "panda-4points", "--hardware", str(f), "--yes"])
    finally:
        proc.kill()
        proc.wait(timeout=30)
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "Traceback" not in err, err
    assert f"nobody subscribes to {topic} within 0.3 s" in err


@pytest.fixture
def arm(tmp_path: Path) -> Any:
    """The rehearsal arm of panda-4points in its own process; yields (process, stats file)."""
    stats = tmp_path / "arm.json"
    cmd = [
        *CLI,
        "sim-arm",
        "panda-4points",
        "--domain-id",
        str(DOMAIN),
        "--joint-states",
        JOINT_STATES,
        "--command",
        COMMAND,
        "--duration",
        "120",
        "--out",
        str(stats),
        "--command-timeout",
        "0.1",
    ]
    proc = subprocess.Popen(cmd, env=ENV, stderr=subprocess.PIPE)
    yield proc, stats
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)


def _stop(proc: subprocess.Popen[bytes], stats: Path) -> dict[str, Any]:
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 0
    result: dict[str, Any] = json.loads(stats.read_text())
    return result


def test_panda_4points_converges_through_dds_against_the_rehearsal_arm(
    tmp_path: Path, arm: Any
) -> None:
    out = tmp_path / "run"
    f = hardware(tmp_path)
    code = main(["servo", "panda-4points", "--hardware", str(f), "--yes", "--out", str(out)])
    summary = json.loads((out / "summary.json").read_text())
    assert code == 0 and summary["outcome"] == "converged", summary["reason"]
    timing = json.loads((out / "timing.json").read_text())
    assert timing["iterations"] == summary["iterations"] and timing["jitter_p99"] is not None
    assert timing["scheduling"].startswith(("SCHED_FIFO 50", "SCHED_OTHER (SCHED_FIFO 50 refused"))
    assert (out / "scenario.toml").exists() and (out / "log.npz").exists()
    stats = _stop(*arm)
    assert stats["commands"] >= summary["iterations"] and stats["refused"] == 0
    assert stats["last_command"] == [0.0] * 7 and stats["fault"] is None
    print("timing", timing, "arm", {k: v for k, v in stats.items() if k != "stopped_after"})


def test_killing_the_arm_ends_the_run_stale(tmp_path: Path, arm: Any) -> None:
    proc, _ = arm
    node = Ros2Node(DOMAIN)
    seen = node.reader(COMMAND, Float64MultiArray)
    out = tmp_path / "run"
    f = hardware(tmp_path)
    servo = subprocess.Popen(
        [*CLI, "servo", "panda-4points", "--hardware", str(f), "--yes", "--out", str(out)],
        env=ENV,
    )
    deadline = time.monotonic() + 90
    while not seen.take(N=10) and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.kill()
    assert servo.wait(timeout=60) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "stale_measurement", summary["reason"]
    assert "no fresh joint readings" in summary["reason"]
    print(summary["reason"])


def test_killing_redservo_stops_the_arm_by_itself(tmp_path: Path, arm: Any) -> None:
    node = Ros2Node(DOMAIN)
    seen = node.reader(COMMAND, Float64MultiArray)
    f = hardware(tmp_path)
    servo = subprocess.Popen(
        [
            *CLI,
            "servo",
            "panda-4points",
            "--hardware",
            str(f),
            "--yes",
            "--out",
            str(tmp_path / "run"),
        ],
        env=ENV,
    )
    moving, deadline = False, time.monotonic() + 90
    while not moving and time.monotonic() < deadline:
        moving = any(any(msg.data) for msg in seen.take(N=10))
        time.sleep(0.02)
    assert moving
    servo.send_signal(signal.SIGKILL)
    servo.wait(timeout=30)
    time.sleep(0.5)
    stats = _stop(*arm)
    assert stats["timeouts"] == 1 and stats["last_command"] == [0.0] * 7
    print("stopped after", stats["stopped_after"])


def test_a_dry_run_sends_nothing(tmp_path: Path, arm: Any) -> None:
    out = tmp_path / "run"
    f = hardware(tmp_path, "[loop]\nduration = 1.0\n")
    code = main(
        ["servo", "panda-4points", "--hardware", str(f), "--yes", "--dry-run", "--out", str(out)]
    )
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["iterations"] >= 10
    stats = _stop(*arm)
    assert stats["commands"] == 0 and stats["timeouts"] == 0


def test_the_rate_bridge_publishes_faster_than_the_loop(tmp_path: Path, arm: Any) -> None:
    out = tmp_path / "run"
    f = hardware(tmp_path, "publish_rate = 200.0\n[loop]\nduration = 2.0\n")
    code = main(["servo", "panda-4points", "--hardware", str(f), "--yes", "--out", str(out)])
    assert code == 0
    iterations = json.loads((out / "summary.json").read_text())["iterations"]
    stats = _stop(*arm)
    assert stats["commands"] > 2 * iterations and stats["refused"] == 0
    assert stats["last_command"] == [0.0] * 7


def test_a_speed_scale_out_of_range_is_one_line(tmp_path: Path, capsys: Any) -> None:
    f = hardware(tmp_path)
    assert main(["servo", "panda-4points", "--hardware", str(f), "--speed-scale", "1.5"]) == 2
    assert "--speed-scale must be in (0, 1], got 1.5" in capsys.readouterr().err


def test_not_confirmed_sends_nothing(tmp_path: Path, arm: Any, monkeypatch: Any) -> None:
    monkeypatch.setattr("builtins.input", lambda: "n")
    f = hardware(tmp_path)
    assert main(["servo", "panda-4points", "--hardware", str(f)]) == 1
    assert _stop(*arm)["commands"] == 0


def test_the_in_process_mujoco_driver_runs_the_same_loop(tmp_path: Path) -> None:
    out = tmp_path / "run"
    f = tmp_path / "hw.toml"
    f.write_text('[robot]\ndriver = "mujoco"\n[loop]\nduration = 1.0\n')
    assert main(["servo", "panda-4points", "--hardware", str(f), "--yes", "--out", str(out)]) == 0
    assert json.loads((out / "summary.json").read_text())["iterations"] >= 10


@pytest.mark.parametrize("command", ["servo", "sim-arm"])
def test_help_documents_the_commands(command: str, capsys: Any) -> None:
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0 and "usage: redservo " + command in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "expect"),
    [
        (["--joints", "a,a,b,c,d,e,f"], "--joints names ['a'] more than once"),
        (["--rate", "5"], "rate must be 10-1000 Hz"),
        (["--command", "/bad topic"], "command = '/bad topic' is not a fully qualified"),
        (["--domain-id", "999"], "domain_id must be 0-232"),
    ],
)
def test_sim_arm_bad_options_are_one_line(argv: list[str], expect: str, capsys: Any) -> None:
    assert main(["sim-arm", "panda-4points", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and expect in err, err


def test_a_missing_hardware_file_is_one_line(tmp_path: Path, capsys: Any) -> None:
    f = tmp_path / "nope.toml"
    assert main(["servo", "panda-4points", "--hardware", str(f)]) == 2
    assert f"{f}: cannot read the hardware file" in capsys.readouterr().err
