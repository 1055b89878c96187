"""What a :class:`~redservo.control.Controller` takes and returns at each step.

Units: seconds, metres, radians; features in normalized image units; commands in rad/s or
m/s per joint.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

from redservo._validation import FloatArray
from redservo.records.lazy import LazyRecord
from redservo.redundancy.base import Diagnostics
from redservo.scene import Scene
from redservo.task import TaskState

__all__ = ["ControlStep", "Features", "Measurement", "SceneContext"]


class Features(Protocol):
    """A measurement of the task's features: anything with ``s`` and ``inv_depth`` (a
    :class:`Measurement`, the servo loop's ``FeatureMeasurement``, a sensor's reading)."""

    @property
    def s(self) -> FloatArray: ...

    @property
    def inv_depth(self) -> Sequence[FloatArray]: ...


class Measurement(NamedTuple):
    """Measured features: ``s`` (k,) stacked in the task's term order (normalized image
    units) and the inverse-depth parameters per term (1/m for a point) the controller uses."""

    s: FloatArray
    inv_depth: tuple[FloatArray, ...]
    stamp: float | None = None
    """When the features were true (s, the image's exposure; :mod:`redservo.sensors.timing`),
    or None: at the step's ``t``. The controller brings an older one to the present
    (:mod:`redservo.control.latency`)."""


class SceneContext(NamedTuple):
    """What only a simulator knows: the scene and the true camera pose (4x4, base frame).

    Given to :meth:`~redservo.control.Controller.step`, it reaches the objectives
    (``ctx.scene``, ``ctx.bMc``) and the ``"known"`` feed-forward."""

    scene: Scene
    bMc: FloatArray


class ControlStep(LazyRecord):
    """What one :meth:`~redservo.control.Controller.step` decided.

    A read-only record (:class:`~redservo.records.lazy.LazyRecord`): ``step.qdot``,
    ``qdot, state, *_ = step``, ``step[0]``, ``len``, ``==``, ``repr``, pickling,
    ``_fields``, ``_asdict()`` and ``_replace()`` work as on the ``NamedTuple`` it was up
    to 0.1.0; it is no longer a ``tuple`` (``isinstance(step, tuple)`` is False).
    ``ControlStep(qdot, state, diagnostics, secondary, de1_dt, stop, saturated)`` (or by
    keyword) makes one. The compiled engine's step makes its fields from the kernel's
    buffer when they are first read (:class:`redservo.control.kernel_step.KernelStep`):
    each step has its own arrays, so a step a caller keeps never changes.
    """

    __slots__ = ()
    _fields = ("qdot", "state", "diagnostics", "secondary", "de1_dt", "stop", "saturated")

    qdot: FloatArray
    """(n,) the command to send (rad/s or m/s); zeros when ``stop`` is set."""
    state: TaskState
    """The task at this step (``e1``, ``J1``, ``s``, ``L``, ...)."""
    diagnostics: Diagnostics | None
    """The law's diagnostics; None when an objective stopped the run (no law call)."""
    secondary: FloatArray | None
    """(n,) the sum of the objectives' commands given to the law (rad/s or m/s), or None."""
    de1_dt: FloatArray | None
    """(m,) the feed-forward given to the law (task units/s), or None."""
    stop: str | None
    """The outcome an objective ended the run with (e.g. ``"occluded"``), or None."""
    saturated: bool
    """The output saturation scaled the law's command down."""
