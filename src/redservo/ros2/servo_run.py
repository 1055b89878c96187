"""``redservo servo``: a scenario's controller on the arm a hardware file describes.

:func:`servo_on_hardware` connects (:mod:`redservo.ros2.robot` or the in-process MuJoCo
arm), checks everything before the first command (the joint states arrive, name every
joint, lie within the limits and within ``robot.start_tolerance`` of the scenario's
``q0``), asks for confirmation, runs :class:`~redservo.hardware.ServoLoop` and writes the
run directory of a simulation (``summary.json``, ``log.npz``, ``log.csv``,
``diagnostics.json``, ``scenario.toml``, ``run.json``) plus ``timing.json``: the loop's
period jitter and the joint states' ages (:mod:`redservo.ros2.timing`).

Units: seconds, radians.
"""

from __future__ import annotations

import dataclasses
import signal
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.experiment.build import Experiment
from redservo.hardware import IdealFeatureSource, ServoLoop
from redservo.hardware.realtime import quiet_interpreter, realtime_scheduling
from redservo.hardware.recorder import ServoResult
from redservo.hardware.waiting import HybridSleep
from redservo.ros2.hardware_file import HardwareSpec

__all__ = ["DryRunRobot", "JointPose", "check_start", "servo_on_hardware"]


class DryRunRobot:
    """Reads the arm, never commands it: the commands are only recorded (``--dry-run``)."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.commands: list[FloatArray] = []

    def read_joints(self) -> tuple[float, FloatArray]:
        t, q = self.inner.read_joints()
        return t, q

    def send_velocity(self, qdot: FloatArray) -> None:
        self.commands.append(np.array(qdot, dtype=float))

    def stop(self) -> None:
        """Nothing to stop: nothing was sent."""


class JointPose:
    """The camera pose from the *measured* joints and the model (the ``simulated`` camera)."""

    def __init__(self, robot: Any, model: Any, t_start: float) -> None:
        self.robot, self.model, self.t_start = robot, model, t_start

    def true_pose(self) -> FloatArray:
        """``bMc`` at the newest joint reading the loop took (takes no message when the robot
        has ``latest_joints``: the tracker's thread calls this)."""
        latest = getattr(self.robot, "latest_joints", None)
        reading = latest() if latest is not None else None
        _, q = reading if reading is not None else self.robot.read_joints()
        pose: FloatArray = self.model.fkine(q, check_limits=False)
        return pose


def check_start(exp: Experiment, q: FloatArray, spec: HardwareSpec, joints: list[str]) -> None:
    """Refuse to start when the arm is outside its limits or far from the scenario's ``q0``.

    Raises:
        ConfigurationError: naming the joint, its position and what is allowed.
    """
    lim = exp.limits
    for i, name in enumerate(joints):
        if not lim.q_min[i] <= q[i] <= lim.q_max[i]:
            raise ConfigurationError(
                f"joint {name} is at {q[i]:.4f} rad, outside its limits [{lim.q_min[i]:.4f}, "
                f"{lim.q_max[i]:.4f}]: nothing was sent",
                argument="robot.joints",
            )
    far = np.abs(q - exp.q0)
    i = int(np.argmax(far))
    if far[i] > spec.robot.start_tolerance:
        raise ConfigurationError(
            f"{spec.path}: key 'robot.start_tolerance': joint {joints[i]} is at {q[i]:.4f} rad, "
            f"{far[i]:.4f} rad from the scenario's q0 = {exp.q0[i]:.4f} (allowed "
            f"{spec.robot.start_tolerance:g} rad): move the arm to the scenario's start first; "
            "nothing was sent",
            argument="robot.start_tolerance",
        )


@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM during the run: a KeyboardInterrupt, so the loop stops the arm first."""

    def handler(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    try:
        old = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _connect(exp: Experiment, spec: HardwareSpec, period: float) -> tuple[Any, list[str]]:
    joints = spec.robot.joints or list(exp.robot.joint_names)
    if len(joints) != exp.robot.n:
        raise ConfigurationError(
            f"{spec.path}: key 'robot.joints': names {len(joints)} joints; the scenario's "
            f"{exp.robot.name} has {exp.robot.n}",
            argument="robot.joints",
        )
    if spec.robot.driver == "mujoco":
        from redservo.physics.arm import MujocoArm
        from redservo.physics.robot import MujocoRobot

        arm = MujocoArm(exp.robot, exp.scene, camera=exp.camera, q_ref=exp.q0)
        return MujocoRobot(arm, exp.q0, period=period), joints
    from redservo.ros2.robot import Ros2Robot
    from redservo.ros2.transport import Ros2Node

    node = Ros2Node(spec.robot.domain_id, network=spec.robot.network)  # type: ignore[arg-type]
    robot = Ros2Robot(
        node,
        joints,
        joint_states=spec.robot.joint_states,
        command=spec.robot.command,
        own_node=True,
    )
    try:
        robot.wait_for_joints(spec.robot.wait)
    except BaseException:
        robot.close()
        raise
    return robot, joints


def _source(exp: Experiment, spec: HardwareSpec, hw: Any) -> Any:
    """The feature source ``[camera]`` asks for (checked: ``CameraInfo`` arrives)."""
    pose = JointPose(hw, exp.robot, time.monotonic())
    cam = spec.camera
    if cam.driver == "simulated":
        return IdealFeatureSource(exp.task, exp.scene, pose)  # type: ignore[arg-type]
    source: Any
    if cam.driver == "video":
        from redservo.hardware.video import VideoSource

        source = VideoSource(
            cam.file, exp.camera, exp.task, exp.scene, pose, dot_threshold=cam.dot_threshold
        )
    elif cam.driver == "device":
        from redservo.hardware.device import DeviceSource, open_device

        capture = open_device(cam.device, exp.camera)
        source = DeviceSource(
            capture,
            exp.camera,
            exp.task,
            exp.scene,
            pose,
            latency=cam.latency,
            dot_threshold=cam.dot_threshold,
            name=f"the camera {cam.device!r}",
        )
    else:
        from redservo.ros2.image_source import Ros2ImageSource, wait_for_camera

        camera = wait_for_camera(hw.node, cam.camera_info, spec.robot.wait)
        source = Ros2ImageSource(
            hw.node, cam.image, camera, exp.task, exp.scene, pose, hw.stamps, cam.dot_threshold
        )
    try:
        source.first_measurement(spec.robot.wait)  # the target is seen before any command
    except BaseException:
        source.close()
        raise
    return source


def _servo_loop(
    exp: Experiment,
    spec: HardwareSpec,
    hw: Any,
    source: Any,
    limits: Any,
    period: float,
    dry_run: bool,
) -> ServoLoop:
    """The loop on ``hw`` (recording only when ``dry_run``; through the rate bridge when
    ``robot.publish_rate`` is set)."""
    robot: Any = DryRunRobot(hw) if dry_run else hw
    if spec.robot.publish_rate > 0.0 and not dry_run:
        from redservo.ros2.bridge import RateBridge

        robot = RateBridge(
            hw,
            exp.robot.n,
            rate=spec.robot.publish_rate,
            qddot_max=limits.qddot_max,
            hold_timeout=spec.loop.watchdog_timeout,
        )
    opts = exp.options
    return ServoLoop(
        robot,
        source,
        exp.robot,
        exp.task,
        exp.law,
        limits,
        period=period,
        lam=opts.lam,
        watchdog_timeout=spec.loop.watchdog_timeout,
        clock_tolerance=spec.loop.clock_tolerance,
        tolerance=opts.tolerance,
        max_iterations=None if spec.loop.duration else opts.max_iterations,
        duration=spec.loop.duration,
        sleep=HybridSleep(spec.loop.spin),
    )


def servo_on_hardware(
    exp: Experiment,
    spec: HardwareSpec,
    *,
    dry_run: bool = False,
    speed_scale: float = 1.0,
    confirm: Callable[[str], bool] | None = None,
) -> tuple[ServoResult | None, dict[str, Any]]:
    """Check, confirm, run; return the result (None when not confirmed) and the timing.

    Args:
        exp: The built scenario.
        spec: The hardware file.
        dry_run: Compute and record the commands, send none.
        speed_scale: Factor (0, 1] on the velocity limits.
        confirm: Asked with a description before the first command; None: no question.

    Raises:
        ConfigurationError: a bad ``speed_scale``, an arm outside its limits or far from the
            scenario's start (nothing is sent), or a bad hardware file value.
        MessageError: no usable ``JointState`` arrived, or nobody subscribes to the command
            topic within ``robot.command_wait`` (not checked in a dry run: nothing is sent).
    """
    from redservo.ros2.timing import timing_report

    if not (0.0 < speed_scale <= 1.0):
        raise ConfigurationError(
            f"--speed-scale must be in (0, 1], got {speed_scale!r}", argument="speed_scale"
        )
    limits = exp.limits
    if speed_scale < 1.0 and limits.qdot_max is not None:
        limits = dataclasses.replace(limits, qdot_max=limits.qdot_max * speed_scale)
    period = spec.loop.period or exp.options.dt
    exp.run(max_iterations=2)  # compile (or load) the law's kernels before the real-time loop
    hw, joints = _connect(exp, spec, period)
    source = None
    try:
        if not dry_run and hasattr(hw, "wait_for_subscriber"):
            hw.wait_for_subscriber(spec.robot.command_wait)  # the controller reads commands
        _, q = hw.read_joints()
        check_start(exp, np.asarray(q, dtype=float), spec, joints)
        source = _source(exp, spec, hw)  # the camera is checked before the question too
        what = (
            f"{exp.scenario.name} on {spec.robot.driver} ({spec.robot.command}, domain "
            f"{spec.robot.domain_id}), {'DRY RUN' if dry_run else 'commands WILL be sent'}, "
            f"speed scale {speed_scale:g}"
        )
        if confirm is not None and not confirm(what):
            return None, {}
        loop = _servo_loop(exp, spec, hw, source, limits, period, dry_run)
        rt = realtime_scheduling(spec.loop.realtime_priority, getattr(source, "threads", []))
        with _sigterm_as_interrupt(), quiet_interpreter(), rt as scheduling:
            result = loop.run(raise_errors=False)
        # what write_run_files records of the controller (as a simulation result has it)
        result.engine = loop.controller.engine  # type: ignore[attr-defined]
        result.engine_reason = loop.controller.engine_reason  # type: ignore[attr-defined]
        timing = timing_report(result, period, hw, source)
        timing["scheduling"] = scheduling
        return result, timing
    finally:
        for part in (source, hw):
            close = getattr(part, "close", None)
            if close is not None:
                close()


def save_run(result: ServoResult, exp: Experiment, out: Path, timing: dict[str, Any]) -> Path:
    """Write the run directory (module docstring)."""
    import json

    from redservo.runs.provenance import write_run_files

    sc = exp.scenario
    result.save(out, extra={"scenario": sc.name, "source": sc.source, "method": sc.method})
    result.provenance = exp._provenance(None, None, exp.options)  # type: ignore[attr-defined]
    write_run_files(out, result)  # type: ignore[arg-type]
    (out / "timing.json").write_text(json.dumps(timing, indent=2) + "\n")
    return out
