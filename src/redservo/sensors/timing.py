"""A real camera's timing around any sensor: frame rate, latency and exposure.

A perfect sensor (the default) measures the features at every control period, at the
instant of the control step, with no delay and no blur. A real camera takes frames at its
own ``rate`` (Hz), each exposed for ``exposure`` seconds, and delivers the measurement
``latency`` seconds after the **middle of the exposure** (the instant the measurement
describes, its **stamp**). :class:`TimedSensor` wraps any
:class:`~redservo.sensors.Sensor` so that every loop honours this the same way:

* frame ``j`` is exposed around ``t_j = j / rate`` (``j`` an integer; without a ``rate``,
  one frame every control period ``dt``), i.e. over ``[t_j − exposure/2, t_j + exposure/2]``;
* its measurement is available from ``t_j + latency`` on, not before; between two
  available frames the loop gets the last available one again (**holding**), stamped with
  its exposure time ``t_j`` (:attr:`SensorReading.stamp`);
* the camera pose during an exposure is interpolated between the control steps' poses
  (linear in translation, geodesic in rotation); the world before the run's start
  (``t < 0``) is the world at ``t = 0`` (the robot at rest at ``q0``, the camera already
  running), so a measurement exists at the first step;
* **exposure**: an image sensor (one with a ``renderer``) detects in one frame rendered with
  the motion blur of the camera's actual motion during the exposure
  (:mod:`redservo.vision.motion_blur`); the ideal sensor averages the features over
  ``EXPOSURE_SAMPLES`` instants of the exposure window;
* a **live** sensor (``live = True``: the MuJoCo camera, which renders the physics' present
  state) takes each frame at the first control step after its exposure time, stamped with
  that step's time (a frame exposed before the start keeps its time: the world was at rest),
  and cannot model an exposure.

Units: seconds, Hz.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from redservo._validation import FloatArray, as_transform
from redservo.errors import ConfigurationError
from redservo.kernels import lazy
from redservo.sensors import IdealSensor, Sensor, SensorReading

if TYPE_CHECKING:  # pragma: no cover
    from redservo.scene import Scene
    from redservo.task import VisualTask

if TYPE_CHECKING:  # the kernel module, typed; imported on first use at run time
    from redservo.kernels import interp as _KI
else:
    _KI = lazy("interp")  # the command line starts without numba

__all__ = [
    "EXPOSURE_SAMPLES",
    "MAX_LATENCY",
    "MAX_RATE",
    "CameraTiming",
    "TimedSensor",
    "timed",
]

MAX_RATE = 10_000.0
"""Highest frame rate (Hz) a scenario may declare: 10 kHz."""
MAX_LATENCY = 0.5
"""Latency (s) from which a measurement is refused: the servo loop's default
``watchdog_timeout`` (:class:`redservo.hardware.ServoLoop`), beyond which its measurements
are stale on arrival and the compensation has no command history to bridge them."""
EXPOSURE_SAMPLES = 5
"""Instants of the exposure window averaged (ideal sensor) or rendered (image sensor)."""

_EPS = 1e-9  # s: roundoff of frame and step times


@dataclass(frozen=True)
class CameraTiming:
    """A camera's timing (module docstring).

    Attributes:
        rate: Frames per second (Hz, (0, 10 kHz]), or None: one frame every control period.
        latency: Middle of the exposure to the measurement available (s, [0, 0.5)).
        exposure: Exposure time (s, >= 0, at most the frame interval).
    """

    rate: float | None = None
    latency: float = 0.0
    exposure: float = 0.0

    def __post_init__(self) -> None:
        rate_ok = self.rate is None or (math.isfinite(self.rate) and 0 < self.rate <= MAX_RATE)
        checks = (
            ("rate", rate_ok, f"None or in (0, {MAX_RATE:g}] Hz"),
            ("latency", 0.0 <= self.latency < MAX_LATENCY, f"in [0, {MAX_LATENCY:g}) s"),
            ("exposure", 0.0 <= self.exposure <= 1.0, "in [0, 1] s"),
        )
        for name, ok, allowed in checks:
            if not ok:
                value = getattr(self, name)
                raise ConfigurationError(f"{name} = {value!r}: allowed {allowed}", argument=name)
        if self.latency < self.exposure / 2.0:
            raise ConfigurationError(
                f"latency {self.latency:g} s < exposure/2: a frame is read after its exposure",
                argument="latency",
            )

    @property
    def perfect(self) -> bool:
        """True for today's perfect camera: a frame every period, no latency, no blur."""
        return self.rate is None and self.latency == 0.0 and self.exposure == 0.0

    def interval(self, dt: float) -> float:
        """The frame interval (s) with control period ``dt`` (s)."""
        return dt if self.rate is None else 1.0 / self.rate


def _interpolate(T0: FloatArray, T1: FloatArray, u: float) -> FloatArray:
    """The pose a fraction ``u`` in [0, 1] of the way from ``T0`` to ``T1`` (4x4): linear in
    translation, geodesic in rotation (compiled: :func:`redservo.kernels.interp.interpolate_pose`)."""
    out: FloatArray = _KI.interpolate_pose(T0, T1, float(u))
    return out


class TimedSensor:
    """``sensor`` seen through a camera's ``timing``, in a loop of period ``dt`` (s).

    Raises:
        ConfigurationError: ``timing`` has an exposure and ``sensor`` can neither render
            one (an image sensor with a ``renderer``) nor be averaged (an :class:`IdealSensor`); or the exposure
            is longer than the frame interval.
    """

    def __init__(self, sensor: Sensor, timing: CameraTiming, dt: float) -> None:
        self.live = bool(getattr(sensor, "live", False))
        exposed = hasattr(sensor, "renderer") or isinstance(sensor, IdealSensor)
        if timing.exposure > 0.0 and (self.live or not exposed):
            raise ConfigurationError(
                f"{type(sensor).__name__} cannot model an exposure (it renders only the "
                "present, or renders no image to blur): use exposure = 0",
                argument="exposure",
            )
        if timing.exposure > timing.interval(dt) + _EPS:
            raise ConfigurationError(
                f"exposure {timing.exposure:g} s is longer than the frame interval "
                f"{timing.interval(dt):g} s",
                argument="exposure",
            )
        self.sensor, self.timing, self.dt = sensor, timing, float(dt)
        self._offsets = (np.linspace(-0.5, 0.5, EXPOSURE_SAMPLES) * timing.exposure).tolist()
        """The exposure's instants relative to its middle (s)."""
        self.reset()

    def __getattr__(self, name: str) -> object:
        # The wrapped sensor's own attributes (an image sensor's camera, feature_lost, ...).
        if name == "sensor":
            raise AttributeError(name)
        return getattr(self.sensor, name)

    def reset(self) -> None:
        """Forget the frames and poses (start of a run), and reset the wrapped sensor."""
        self.sensor.reset()
        self._poses: list[tuple[float, FloatArray]] = []
        self._queue: list[tuple[float, SensorReading]] = []
        self._current: SensorReading | None = None
        self._next: int | None = None

    def read(self, task: VisualTask, scene: Scene, bMc: FloatArray, t: float) -> SensorReading:
        """The last measurement available at ``t`` (s), stamped with its exposure time, with
        the camera at ``bMc`` (4x4) now; frames whose exposure ended by ``t`` are taken."""
        interval = self.timing.interval(self.dt)
        if self._next is None:  # the camera was running before the start
            self._next = math.floor((-self.timing.latency + _EPS) / interval)
        self._poses.append((float(t), as_transform(bMc, "bMc")))  # checked once, here
        half = self.timing.exposure / 2.0
        while self._next * interval + half <= t + _EPS:
            frame = self._frame(task, scene, self._next * interval)
            assert frame.stamp is not None
            self._queue.append((frame.stamp + self.timing.latency, frame))
            self._next += 1
        while self._queue and self._queue[0][0] <= t + _EPS:
            self._current = self._queue.pop(0)[1]
            if self._current.s is None:  # a lost frame ends the run now, as it would untimed
                break
        self._forget(t - self.timing.latency - interval - self.timing.exposure)
        assert self._current is not None  # the frame available at t = 0 exists
        return self._current

    def _forget(self, before: float) -> None:
        """Drop the poses no future exposure needs (keep one at or before ``before``)."""
        while len(self._poses) > 2 and self._poses[1][0] <= before:
            self._poses.pop(0)

    def _pose(self, t: float) -> tuple[FloatArray, float]:
        """The camera pose at ``t`` (s) and the world's time (``t`` clamped at 0)."""
        poses = self._poses
        world = max(t, 0.0)
        if t <= poses[0][0]:
            return poses[0][1], world
        for (t0, T0), (t1, T1) in itertools.pairwise(poses):
            if t <= t1:
                return _interpolate(T0, T1, (t - t0) / (t1 - t0)), world
        return poses[-1][1], world

    def _frame(self, task: VisualTask, scene: Scene, t_j: float) -> SensorReading:
        """The frame exposed around ``t_j`` (s), stamped ``t_j``."""
        if self.live:  # it renders the present: the frame is taken at this step, stamped so
            t_now, bMc_now = self._poses[-1]
            stamp = t_j if t_j <= 0.0 else t_now  # before the start the world was at rest
            return self.sensor.read(task, scene, bMc_now, t_now)._replace(stamp=stamp)
        if self.timing.exposure <= 0.0:
            bMc, tw = self._pose(t_j)
            reading = self.sensor.read(task, scene, bMc, tw)
        else:
            reading = self._exposed(task, scene, *self._exposure(t_j))
        return reading._replace(stamp=t_j)

    def _exposure(self, t_j: float) -> tuple[list[tuple[FloatArray, float]], FloatArray]:
        """The camera poses and world times of the exposure around ``t_j`` (s) (those of
        :meth:`_pose` at its instants, in one compiled call:
        :func:`redservo.kernels.interp.poses_at`), and the poses stacked (instants, 4, 4)."""
        at = [t_j + dt for dt in self._offsets]
        times = np.array([t for t, _ in self._poses])
        poses: FloatArray = _KI.poses_at(times, np.array([T for _, T in self._poses]), np.array(at))
        return [(poses[k], max(t, 0.0)) for k, t in enumerate(at)], poses

    def _exposed(
        self,
        task: VisualTask,
        scene: Scene,
        samples: list[tuple[FloatArray, float]],
        stacked: FloatArray,
    ) -> SensorReading:
        renderer = getattr(self.sensor, "renderer", None)
        if renderer is not None:  # an image sensor: one motion-blurred frame
            from redservo.vision.motion_blur import exposed_frame

            bMc, tw = samples[len(samples) // 2]
            image = exposed_frame(renderer, scene, samples, stacked)  # computed where read
            out: SensorReading = cast(Any, self.sensor).read(task, scene, bMc, tw, image)
            return out
        readings = [self.sensor.read(task, scene, T, tw) for T, tw in samples]
        values = [r.s for r in readings if r.s is not None]
        if len(values) < len(readings):  # lost during the exposure: that reading says why
            return next(r for r in readings if r.s is None)
        return readings[len(readings) // 2]._replace(s=np.mean(values, axis=0))


def timed(sensor: Sensor | None, timing: CameraTiming, dt: float) -> Sensor | None:
    """``sensor`` (None: the ideal sensor) seen through ``timing`` with control period ``dt``
    (s): a :class:`TimedSensor`, or ``sensor`` itself for the perfect camera or when it is
    timed already."""
    if timing.perfect or isinstance(sensor, TimedSensor):
        return sensor
    return TimedSensor(IdealSensor() if sensor is None else sensor, timing, dt)
