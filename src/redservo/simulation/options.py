"""Options of :func:`redservo.simulation.simulate` (units: s, m, rad, 1/s)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from redservo._validation import FloatArray, as_transform
from redservo.control.avoidance import Collision
from redservo.control.feedforward import FEEDFORWARD_MODES, Feedforward
from redservo.control.image_motion import ImageMotionLimit
from redservo.control.objectives import Occlusion
from redservo.errors import ConfigurationError
from redservo.redundancy.gain import AdaptiveGain

__all__ = ["Feedforward", "Occlusion", "SimulationOptions"]


@dataclass(frozen=True, kw_only=True)
class SimulationOptions:
    """Options of :func:`~redservo.simulation.simulate`.

    Attributes:
        lam: Gain λ (1/s), or an :class:`~redservo.AdaptiveGain` λ(‖e1‖∞).
        dt: Control period (s).
        max_iterations: Iteration cap.
        tolerance: Convergence threshold on ``‖e1‖`` (task units).
        rho: Band width of the joint-limit thresholds (CM01 eq. 3).
        min_margin: Success criterion: every joint stays at least this fraction of its
            range from its hard limits all along the run (default 0.01).
        qdot_max: Actuator saturation applied *after* the law (scalar or (n,), rad/s or
            m/s): the whole command is scaled down uniformly (direction kept). None = none.
            The joint velocity limits every law honours are those of the ``limits``.
        noise_std: Standard deviation of additive noise on the features (feature units).
        seed: Seed of the noise generator.
        depth_scale: The controller's depth estimate is ``Ẑ = depth_scale · Z``.
        eMc_model: 4x4 hand-eye transform the *controller* believes in (None =
            the true one); models a calibration error.
        feedforward: ``"none"``, ``"known"`` (∂e1/∂t from the target's known
            motion) or ``"estimated"`` (``(e1_k - e1_{k-1})/dt - J1 q̇_{k-1}``).
        image_margin_px: A feature point closer than this to the image border counts as lost.
        check_image: Stop with ``target_lost`` when an object leaves the image.
        occlusion: Occlusion set-up (:class:`~redservo.control.Occlusion`), or None.
        image_motion: The controller's camera-motion limit
            (:class:`~redservo.control.ImageMotionLimit`), or None.
        stop_at_convergence: Stop as soon as ``‖e1‖ < tolerance``. Set False for
            tracking tasks: the run then lasts ``max_iterations`` and its outcome is
            ``converged`` when the final error is below the tolerance.
        collision: Obstacles and collision avoidance
            (:class:`~redservo.control.avoidance.Collision`), or None. With obstacles or
            self pairs, every step's smallest distance is logged and a distance <= 0 ends
            the run with outcome ``collision``; unless it is off, the controller avoids
            (repulsive objective) and shields (distance shield).
        compensate_latency: The controller brings a camera's delayed measurement to the
            present (:mod:`redservo.control.latency`); only stamped measurements (a sensor
            with a latency or a frame rate, :mod:`redservo.sensors.timing`) are affected.
    """

    lam: float | AdaptiveGain = 0.5
    dt: float = 0.04
    max_iterations: int = 1000
    tolerance: float = 1e-3
    rho: float = 0.1
    min_margin: float = 0.01
    qdot_max: float | tuple[float, ...] | None = None
    noise_std: float = 0.0
    seed: int = 0
    depth_scale: float = 1.0
    eMc_model: FloatArray | None = None
    feedforward: Feedforward = "none"
    image_margin_px: float = 0.0
    check_image: bool = True
    occlusion: Occlusion | None = None
    stop_at_convergence: bool = True
    image_motion: ImageMotionLimit | None = None
    collision: Collision | None = None
    compensate_latency: bool = True

    @property
    def constant_lam(self) -> float:
        """The gain λ (1/s) when it is constant; raises for an adaptive gain."""
        if isinstance(self.lam, AdaptiveGain):
            raise ConfigurationError(
                "this needs a constant gain lam, not an AdaptiveGain", argument="lam"
            )
        return float(self.lam)

    def __post_init__(self) -> None:
        lam_ok = isinstance(self.lam, AdaptiveGain) or _finite_positive(self.lam)
        checks: list[tuple[str, bool, str]] = [
            ("lam", lam_ok, "a finite positive gain (1/s) or an AdaptiveGain"),
            ("dt", _finite_positive(self.dt), "a finite positive period (s)"),
            ("max_iterations", self.max_iterations >= 1, "at least 1"),
            ("tolerance", _finite_positive(self.tolerance), "positive"),
            ("rho", 0 < self.rho < 0.5, "in (0, 0.5)"),
            ("min_margin", 0.0 <= self.min_margin < 0.5, "in [0, 0.5)"),
            ("noise_std", self.noise_std >= 0, "non-negative"),
            ("depth_scale", _finite_positive(self.depth_scale), "positive"),
            ("image_margin_px", self.image_margin_px >= 0, "non-negative"),
        ]
        for name, ok, allowed in checks:
            if not ok:
                raise ConfigurationError(
                    f"{name} must be {allowed}, got {getattr(self, name)!r}", argument=name
                )
        if self.qdot_max is not None and np.any(np.asarray(self.qdot_max, dtype=float) <= 0):
            raise ConfigurationError(
                f"qdot_max must be positive, got {self.qdot_max!r}", argument="qdot_max"
            )
        if self.feedforward not in FEEDFORWARD_MODES:
            raise ConfigurationError(
                f"feedforward must be 'none', 'known' or 'estimated', got {self.feedforward!r}",
                argument="feedforward",
            )
        if self.collision is not None and not isinstance(self.collision, Collision):
            raise ConfigurationError(
                f"collision must be a redservo.control.avoidance.Collision or None, got "
                f"{self.collision!r:.60}",
                argument="collision",
            )
        if self.eMc_model is not None:
            object.__setattr__(self, "eMc_model", as_transform(self.eMc_model, "eMc_model"))


def _finite_positive(value: object) -> bool:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        return False
    return math.isfinite(float(value)) and float(value) > 0.0
