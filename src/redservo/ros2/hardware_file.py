"""The hardware file of ``redservo servo SCENARIO --hardware FILE.toml``.

::

    [robot]
    driver = "ros2"                       # ros2 | mujoco (the scenario's MuJoCo arm, in process)
    joint_states = "/joint_states"        # JointState topic
    command = "/forward_velocity_controller/commands"   # Float64MultiArray topic
    joints = ["panda_joint1", ...]        # ROS names in the model's joint order (default: model's)
    domain_id = 0                         # ROS_DOMAIN_ID, 0-232
    network = "loopback"                  # loopback (this machine only) | system (CYCLONEDDS_URI)
    wait = 5.0                            # s to wait for the first JointState
    command_wait = 2.0                    # s to wait for a reader of the command topic
    start_tolerance = 0.05                # rad: max |q - the scenario's q0| at the start
    publish_rate = 0.0                    # Hz of the rate bridge (0: one command per period)
    [camera]
    driver = "simulated"                  # simulated (features from the scenario and the
                                          # measured joints) | ros2 (Image + CameraInfo)
                                          # | video (a file played at its frame rate)
                                          # | device (a live camera read through OpenCV)
    image = "/camera/image_raw"           # ros2: Image topic
    camera_info = "/camera/camera_info"   # ros2: CameraInfo topic
    file = "run.mp4"                      # video: the file (relative to this file's folder)
    device = 0                            # device: its index or path (e.g. "/dev/video0")
    latency = 0.0                         # device: s from mid-exposure to delivery
    dot_threshold = 55.0                  # ros2, video: gray level of the dots' ink (0-255)
    [loop]
    watchdog_timeout = 0.2                # s
    period = 0.04                         # s (default: the scenario's control.dt)
    clock_tolerance = 0.005               # s
    duration = 60.0                       # s (default: none; max_iterations of the scenario)
    spin = 0.0                            # s of each wait spent polling the clock (0: sleep)
    realtime_priority = 50                # SCHED_FIFO priority of the loop's thread (0: none)

Every error is one :class:`~redservo.errors.ConfigurationError` naming the file and the key.
Units: seconds, radians, Hz.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from redservo.errors import ConfigurationError
from redservo.ros2.naming import validate_topic

__all__ = ["CameraSpec", "HardwareSpec", "LoopSpec", "RobotSpec", "load_hardware"]


@dataclass
class RobotSpec:
    """``[robot]``."""

    driver: str = "ros2"
    joint_states: str = "/joint_states"
    command: str = "/forward_velocity_controller/commands"
    joints: list[str] | None = None
    domain_id: int = 0
    network: str = "loopback"
    wait: float = 5.0
    command_wait: float = 2.0
    start_tolerance: float = 0.05
    publish_rate: float = 0.0


@dataclass
class CameraSpec:
    """``[camera]``."""

    driver: str = "simulated"
    image: str = "/camera/image_raw"
    camera_info: str = "/camera/camera_info"
    file: str = ""
    device: int | str = 0
    latency: float = 0.0
    dot_threshold: float = 55.0


@dataclass
class LoopSpec:
    """``[loop]``."""

    watchdog_timeout: float = 0.2
    period: float | None = None
    clock_tolerance: float = 0.005
    duration: float | None = None
    spin: float = 0.0
    realtime_priority: int = 50


@dataclass
class HardwareSpec:
    """A parsed hardware file."""

    path: Path
    robot: RobotSpec = field(default_factory=RobotSpec)
    camera: CameraSpec = field(default_factory=CameraSpec)
    loop: LoopSpec = field(default_factory=LoopSpec)


_CHOICES = {
    "robot.driver": ("ros2", "mujoco"),
    "robot.network": ("loopback", "system"),
    "camera.driver": ("simulated", "ros2", "video", "device"),
}
_POSITIVE = {
    "robot.wait",
    "robot.command_wait",
    "robot.start_tolerance",
    "loop.watchdog_timeout",
    "loop.period",
    "loop.duration",
}


class _Reader:
    def __init__(self, path: Path) -> None:
        self.path = path

    def error(self, key: str, text: str) -> ConfigurationError:
        return ConfigurationError(f"{self.path}: key '{key}': {text}", argument=key)

    def value(self, key: str, raw: Any, default: Any) -> Any:
        if key in _CHOICES:
            if raw not in _CHOICES[key]:
                raise self.error(key, f"must be one of {list(_CHOICES[key])}, got {raw!r}")
            return raw
        if key in ("robot.joint_states", "robot.command", "camera.image", "camera.camera_info"):
            try:
                return validate_topic(raw, key)
            except ConfigurationError as exc:
                raise self.error(key, str(exc)) from None
        if key == "robot.joints":
            from redservo.ros2.robot import check_joint_names

            try:
                return check_joint_names(raw, key)
            except ConfigurationError as exc:
                raise self.error(key, str(exc)) from None
        if key == "camera.device":
            index = isinstance(raw, int) and not isinstance(raw, bool) and raw >= 0
            if not (index or (isinstance(raw, str) and raw)):
                raise self.error(key, f"must be a device index >= 0 or a path, got {raw!r}")
            return raw
        if key == "camera.file":
            if not isinstance(raw, str) or not raw:
                raise self.error(key, f"must be the path of a video file, got {raw!r}")
            return str((self.path.parent / raw).resolve())
        if key == "loop.realtime_priority":
            if isinstance(raw, bool) or not isinstance(raw, int) or not 0 <= raw <= 99:
                raise self.error(key, f"must be an integer 0-99 (0: do not ask), got {raw!r}")
            return raw
        if key == "robot.domain_id":
            if isinstance(raw, bool) or not isinstance(raw, int) or not 0 <= raw <= 232:
                raise self.error(key, f"must be an integer 0-232 (ROS_DOMAIN_ID), got {raw!r}")
            return raw
        return self.number(key, raw)

    def number(self, key: str, raw: Any) -> float:
        ok = isinstance(raw, int | float) and not isinstance(raw, bool) and math.isfinite(raw)
        if not ok or raw < 0 or (key in _POSITIVE and raw == 0):
            sign = "> 0" if key in _POSITIVE else ">= 0"
            raise self.error(key, f"must be a number {sign}, got {raw!r}")
        return float(raw)


def load_hardware(path: str | Path) -> HardwareSpec:
    """Read and check a hardware file (module docstring).

    Raises:
        ConfigurationError: the file is unreadable or not TOML, a table or key is unknown, or
            a value is out of range (the message names the file and the key).
    """
    p = Path(path)
    reader = _Reader(p)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigurationError(f"{p}: cannot read the hardware file: {exc.strerror}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigurationError(f"{p}: not a valid TOML file: {exc}") from None
    spec = HardwareSpec(p)
    tables: dict[str, Any] = {"robot": spec.robot, "camera": spec.camera, "loop": spec.loop}
    for name, table in data.items():
        if name not in tables or not isinstance(table, dict):
            raise reader.error(name, f"unknown table; allowed: {sorted(tables)}")
        target = tables[name]
        for key, raw in table.items():
            full = f"{name}.{key}"
            if key not in target.__dataclass_fields__:
                allowed = sorted(target.__dataclass_fields__)
                raise reader.error(full, f"unknown key; allowed in [{name}]: {allowed}")
            setattr(target, key, reader.value(full, raw, getattr(target, key)))
    if spec.camera.driver == "video" and not spec.camera.file:
        raise reader.error("camera.file", "is needed by camera.driver = 'video'")
    if spec.camera.driver == "ros2" and spec.robot.driver != "ros2":
        raise reader.error("camera.driver", "'ros2' needs robot.driver = 'ros2'")
    if spec.loop.clock_tolerance >= spec.loop.watchdog_timeout:
        raise reader.error("loop.clock_tolerance", "must be below loop.watchdog_timeout")
    return spec
