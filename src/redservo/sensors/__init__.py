"""The sensor hook: where the simulator (and the servo loop) gets its feature values.

A sensor turns the world at one instant into *measured* features. The control
law never sees the sensor: the task builds ``e1 = C (s - s*)`` and
``J1 = C L(s, Ẑ) J(q)`` from whatever the sensor measured.

* :class:`IdealSensor` (the default) computes the features from the true pose of
  each object, exactly (the behaviour of every experiment of the papers'
  reproductions).
* ``redservo.vision.ImageSensor`` renders the camera image and detects the
  features in pixels (optional extra ``redservo[vision]``).

A sensor returns a :class:`SensorReading`: the stacked feature values ``s`` (k,)
in normalized image units, the inverse-depth parameters per task term (see
:mod:`redservo.features.base`), and what was lost. ``s`` is None when the
features could not be measured at all at this instant (every dot lost, the
object behind the camera, ...).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple, Protocol, runtime_checkable

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import GeometryError

if TYPE_CHECKING:  # pragma: no cover
    from redservo.scene import Scene
    from redservo.task import VisualTask

__all__ = ["FrameNoise", "IdealSensor", "NoPose", "Sensor", "SensorReading"]


class NoPose(NamedTuple):
    """A frame in which the image sensor's PnP (``depth = "pose"``,
    :func:`redservo.vision.pnp.pose_term_depth`) gave no pose of a point set: its terms'
    interaction matrices keep the depths of the set's last pose (the desired depths before
    the first). The loop raises :attr:`~redservo.redundancy.flags.Flag.NO_POSE` with it
    (:mod:`redservo.sensors.flags`)."""

    frames: int
    """Frames in a row (this one included) without a pose of the point set, >= 1."""
    target: str
    """The point set's object (of the sets without a pose, the one without for longest)."""
    dots: int
    """Its dots detected in this frame."""
    points: int
    """Its points (PnP needs four detected dots at least)."""


class SensorReading(NamedTuple):
    """What a sensor measured at one instant."""

    s: FloatArray | None
    """(k,) stacked feature values (normalized image units), or None when nothing was measured."""
    inv_depth: tuple[FloatArray, ...]
    """Inverse-depth parameters per task term (1/m), as the controller will use them."""
    lost: tuple[int, ...] = ()
    """Indices of the task terms (or dots) that were not detected at this instant."""
    reason: str = ""
    """Why ``s`` is None or something was lost (empty when all is well)."""
    image: object | None = None
    """The image the features were measured in, if the sensor made one: a 2-D uint8 array,
    or for the simulated image sensor a :class:`~redservo.vision.lazyframe.LazyFrame`,
    computed where it was read (``np.asarray(image)`` gives the whole array)."""
    stamp: float | None = None
    """When the image was exposed (s, the middle of the exposure), or None: at the instant
    it was read (an untimed sensor; :mod:`redservo.sensors.timing`)."""
    dots: FloatArray | None = None
    """(N, 2) the normalized image positions of the dots tracked in this frame (the image
    sensor's, in the order of its point sets; a lost dot at its predicted position), or None:
    no dots. A model-based law estimates the target's pose from them (:mod:`redservo.vision.pnp`)."""
    no_pose: NoPose | None = None
    """The point set whose PnP pose this frame could not give (the image sensor's ``depth =
    "pose"``; the depths it used are the last pose's), or None: every pose found, or none
    sought."""


@runtime_checkable
class Sensor(Protocol):
    """Anything that measures the task's features at camera pose ``bMc`` and time ``t``.

    ``reset()`` is called at the start of every run (trackers forget the last frame).
    """

    def reset(self) -> None:
        """Forget any state kept between frames."""

    def read(self, task: VisualTask, scene: Scene, bMc: FloatArray, t: float) -> SensorReading:
        """Measure the features of ``task`` in ``scene`` seen from ``bMc`` (4x4) at ``t`` (s)."""


class IdealSensor:
    """Exact features from the true object poses (no image): the papers' simulations."""

    def reset(self) -> None:
        """Nothing to forget."""

    def read(self, task: VisualTask, scene: Scene, bMc: FloatArray, t: float) -> SensorReading:
        """Return the exact features; ``s`` is None (with the reason) when one is invalid."""
        try:
            s, inv_depth = task.measure(scene, bMc, t)
        except GeometryError as exc:
            return SensorReading(None, (), tuple(range(len(task.terms))), str(exc))
        return SensorReading(s, inv_depth)


class FrameNoise:
    """Additive Gaussian noise of standard deviation ``std`` (feature units) on the features,
    drawn from ``rng`` once per *frame*: a reading the sensor holds (the same
    :class:`SensorReading` again, e.g. a 30 Hz camera read by a faster loop,
    :mod:`redservo.sensors.timing`) keeps the noise it was first given, as the same image
    would. An untimed sensor makes a new reading every period: a draw every period."""

    def __init__(self, std: float, rng: np.random.Generator) -> None:
        self.std, self.rng = float(std), rng
        self._held: tuple[SensorReading | None, FloatArray | None] = (None, None)

    def __call__(self, reading: SensorReading) -> FloatArray:
        """``reading.s`` (not None) plus this frame's noise."""
        assert reading.s is not None
        if self.std <= 0.0:
            return reading.s
        if reading is not self._held[0]:
            self._held = (reading, reading.s + self.rng.normal(0.0, self.std, reading.s.shape[0]))
        s = self._held[1]
        assert s is not None
        return s
