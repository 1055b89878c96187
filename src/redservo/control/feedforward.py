"""The feed-forward term ``∂e1/∂t`` of a moving target (CM01 eq. 2), two ways.

* **estimated** (:class:`FeedforwardEstimator`): from the controller's own successive
  measurements, ``∂e1/∂t ≈ (e1_k − e1_{k−1}) / h − J1_{k−1} q̇_{k−1}``: the change of the
  error minus the part the robot's own motion caused. Any loop can do it (the servo loop of
  a real arm included); it lags one step behind the target.
* **known** (:func:`known_feedforward`): from the target's known motion in the scene, a
  central difference with the camera frozen. Only the simulator knows the scene.

Units: ``e1`` in task units, times in seconds, ``∂e1/∂t`` in task units per second.
"""

from __future__ import annotations

from typing import Literal

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.scene import Scene
from redservo.task import TaskState, VisualTask

__all__ = ["FEEDFORWARD_MODES", "Feedforward", "FeedforwardEstimator", "known_feedforward"]

Feedforward = Literal["none", "known", "estimated"]
FEEDFORWARD_MODES: tuple[Feedforward, ...] = ("none", "known", "estimated")

PERIOD_ROUNDOFF = 1e-9
"""Two measurement times (s) whose difference is within this of the period are one period
apart: the difference of two float times carries their roundoff, the period does not."""


class FeedforwardEstimator:
    """``∂e1/∂t`` estimated from the previous step's ``e1``, ``J1`` and the command since.

    Args:
        dt: The control period (s); the interval ``h`` between two measurements is their time
            difference, taken as exactly ``dt`` when it is within ``PERIOD_ROUNDOFF`` of it.
    """

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self._prev: tuple[FloatArray, FloatArray, float] | None = None

    def reset(self) -> None:
        """Forget the previous measurement (start of a run)."""
        self._prev = None

    def estimate(
        self, state: TaskState, t: float, qdot_prev: FloatArray | None
    ) -> FloatArray | None:
        """Return ``∂e1/∂t`` (m,) at time ``t`` (s), or None at the first step (nothing to
        compare with) and when the previous command ``qdot_prev`` is unknown (None); the
        command ``qdot_prev`` is assumed held since the previous measurement.

        Raises:
            ConfigurationError: ``t`` is not after the previous measurement's time.
        """
        if self._prev is None or qdot_prev is None:
            return None
        e1_prev, J1_prev, t_prev = self._prev
        h = t - t_prev
        if abs(h - self.dt) <= PERIOD_ROUNDOFF:
            h = self.dt
        elif not h > 0.0:
            raise ConfigurationError(
                f"t must increase from one step to the next for the estimated feed-forward, "
                f"got t = {t!r} s after {t_prev!r} s",
                argument="t",
            )
        return (state.e1 - e1_prev) / h - J1_prev @ qdot_prev

    def record(self, state: TaskState, t: float) -> None:
        """Keep ``e1``, ``J1`` and the time ``t`` (s) of the step just commanded."""
        self._prev = (state.e1, state.J1, t)


def known_feedforward(
    task: VisualTask, scene: Scene, bMc: FloatArray, t: float, dt: float
) -> FloatArray:
    """``∂e1/∂t`` (m,) from the target's known motion: central difference with the camera
    frozen at ``bMc`` (4x4), over ``[t − dt/2, t + dt/2]`` (s), clipped at ``t = 0``."""
    h = 0.5 * dt
    s_p, _ = task.measure(scene, bMc, t + h)
    s_m, _ = task.measure(scene, bMc, max(t - h, 0.0))
    ds = task.error(s_p) - task.error(s_m)
    ds /= h + min(h, t)
    return ds if task.C is None else task.C @ ds
