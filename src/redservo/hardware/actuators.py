"""A joint actuator model: transport delay, velocity and acceleration saturation, first-order
lag, and encoder quantization and noise.

:class:`ActuatorModel` is a pure discrete-time object: ``reset(q0)`` then, every control
period ``dt``, ``step(q, qdot_cmd, dt) -> (q_next, qdot_actual)``. It is what
:class:`~redservo.hardware.SimulatedRobot` runs behind the robot interface, and what a
simulator can use instead of the perfect integration ``q + q̇ dt``.

One step, per joint i (``u`` is the command that reaches the drive):

1. **Transport delay** of ``k = delay_steps`` periods: ``u(t) = q̇_cmd(t - k dt)``
   (zero for the first k steps after :meth:`ActuatorModel.reset`).
2. **Velocity saturation**: ``u_i ← clip(u_i, -q̇max_i, q̇max_i)`` (what a drive does: per
   axis; the servo loop scales the whole command before sending it, direction kept).
3. **First-order lag** ``τ_i v̇_i = u_i - v_i``, exact for a command held over the period:
   ``v⁺ = u + (v - u) e^{-dt/τ}``; the position advances by the exact mean velocity
   ``u + (v - u) (τ/dt)(1 - e^{-dt/τ})``. ``τ_i = 0`` means no lag (``v⁺ = u``).
4. **Acceleration saturation**: ``|v⁺_i - v_i| ≤ q̈max_i dt``; where it binds, the step is a
   constant-acceleration ramp (mean velocity ``(v + v⁺)/2``).
5. ``q⁺ = q + v̄ dt``.

The encoder (:meth:`ActuatorModel.encoder`) adds Gaussian noise of std ``encoder_noise_std``
and rounds to a multiple of ``encoder_resolution``.

With every option at its default (:meth:`ActuatorModel.ideal`) a step is exactly
``q + q̇_cmd dt`` and the encoder returns ``q`` unchanged: the ideal robot of the
simulator, bit for bit.

Units: seconds, metres (prismatic) or radians (revolute); velocities per second,
accelerations per second squared.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_vector
from redservo.errors import ConfigurationError, ShapeError

__all__ = ["ACTUATOR_KEYS", "ActuatorModel"]

ACTUATOR_KEYS: dict[str, Any] = {
    "tau": (float, list),
    "delay_steps": int,
    "qdot_max": (float, list),
    "qddot_max": (float, list),
    "encoder_resolution": (float, list),
    "encoder_noise_std": (float, list),
    "seed": int,
}
"""Keys of a scenario's ``[actuators]`` table and their TOML types (the schema entry)."""


def _per_joint(value: ArrayLike | None, name: str, *, positive: bool) -> FloatArray | None:
    """Validate a scalar or (n,) parameter: finite, > 0 (``positive``) or >= 0; None stays None."""
    if value is None:
        return None
    arr = np.asarray(value, dtype=float) if not isinstance(value, np.ndarray) else value
    if arr.ndim > 1 or arr.size == 0:
        raise ConfigurationError(
            f"{name} must be a number or a 1-D list with one value per joint, got {value!r}",
            argument=name,
        )
    arr = np.array(arr, dtype=float)
    bad = ~np.isfinite(arr) | ((arr <= 0.0) if positive else (arr < 0.0))
    if np.any(bad):
        want = "positive" if positive else "non-negative"
        raise ConfigurationError(
            f"{name} must be finite and {want} (per joint), got {value!r}", argument=name
        )
    return arr


class ActuatorModel:
    """Delay, saturation, first-order lag and encoder of a joint-velocity-controlled arm.

    Every per-joint parameter is a scalar (same for all joints) or a list with one value
    per joint; the number of joints is fixed by :meth:`reset`.

    Args:
        tau: Time constant τ of the first-order velocity lag (s), >= 0; 0 = no lag.
        delay_steps: Transport delay k, in control periods (integer >= 0).
        qdot_max: Velocity saturation of the drive (rad/s or m/s), > 0, or None.
        qddot_max: Acceleration saturation (rad/s² or m/s²), > 0, or None.
        encoder_resolution: Encoder step (rad or m), > 0, or None (continuous readings).
        encoder_noise_std: Standard deviation of the reading noise (rad or m), >= 0.
        seed: Seed of the encoder noise generator (re-seeded by :meth:`reset`).

    Raises:
        ConfigurationError: a parameter is negative, zero where it must be positive,
            not finite, or ``delay_steps`` is not a non-negative integer.
    """

    def __init__(
        self,
        *,
        tau: ArrayLike = 0.0,
        delay_steps: int = 0,
        qdot_max: ArrayLike | None = None,
        qddot_max: ArrayLike | None = None,
        encoder_resolution: ArrayLike | None = None,
        encoder_noise_std: ArrayLike = 0.0,
        seed: int | None = None,
    ) -> None:
        if isinstance(delay_steps, bool) or not isinstance(delay_steps, int | np.integer):
            raise ConfigurationError(
                f"delay_steps must be an integer number of periods, got {delay_steps!r}",
                argument="delay_steps",
            )
        if delay_steps < 0:
            raise ConfigurationError(
                f"delay_steps must be >= 0, got {delay_steps!r}", argument="delay_steps"
            )
        self.tau = _per_joint(tau, "tau", positive=False)
        self.delay_steps = int(delay_steps)
        self.qdot_max = _per_joint(qdot_max, "qdot_max", positive=True)
        self.qddot_max = _per_joint(qddot_max, "qddot_max", positive=True)
        self.encoder_resolution = _per_joint(
            encoder_resolution, "encoder_resolution", positive=True
        )
        self.encoder_noise_std = _per_joint(encoder_noise_std, "encoder_noise_std", positive=False)
        self.seed = seed
        self._n = 0
        self._v: FloatArray = np.zeros(0)
        self._queue: collections.deque[FloatArray] = collections.deque()
        self._rng = np.random.default_rng(seed)
        self._lagged = self.tau is not None and bool(np.any(self.tau > 0.0))
        self._noisy = self.encoder_noise_std is not None and bool(
            np.any(self.encoder_noise_std > 0)
        )

    # -- construction --------------------------------------------------------------------------

    @classmethod
    def ideal(cls) -> ActuatorModel:
        """Return the ideal actuator: no lag, no delay, no saturation, exact encoder."""
        return cls()

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str = "actuators") -> ActuatorModel:
        """Build from a scenario's ``[actuators]`` table (keys: :data:`ACTUATOR_KEYS`).

        Raises:
            ConfigurationError: an unknown key or an invalid value; the message names
                ``where.key``.
        """
        unknown = sorted(set(table) - set(ACTUATOR_KEYS))
        if unknown:
            raise ConfigurationError(
                f"key '{where}.{unknown[0]}': unknown key; allowed: {', '.join(ACTUATOR_KEYS)}",
                argument=f"{where}.{unknown[0]}",
            )
        try:
            return cls(**dict(table))
        except ConfigurationError as exc:
            key = exc.argument or ""
            raise ConfigurationError(
                f"key '{where}.{key}': {exc}", argument=f"{where}.{key}"
            ) from None

    @property
    def is_ideal(self) -> bool:
        """True when a step is exactly ``q + q̇ dt`` and the encoder exact."""
        return (
            not self._lagged
            and self.delay_steps == 0
            and self.qdot_max is None
            and self.qddot_max is None
            and self.encoder_resolution is None
            and not self._noisy
        )

    @property
    def velocity(self) -> FloatArray:
        """(n,) the actual joint velocity at the end of the last step (rad/s or m/s)."""
        return self._v.copy()

    def stopping_distance(self, period: float, qdot_max: ArrayLike | None = None) -> FloatArray:
        """Return an upper estimate (n,) of how far a joint still travels after a stop (m or rad).

        A joint moving at ``v = q̇max`` keeps going for the ``k`` periods of delay
        (``v k T``), then the lag adds ``v τ`` (the area under ``v e^{-t/τ}``) and the
        acceleration limit a braking distance ``v² / (2 q̈max)``. Use it as the limits'
        keep-out margin (``JointLimits(..., margin_abs=...)``): the position shield and the
        loop's guard assume a command is executed within the period, this covers the rest.

        Args:
            period: The control period T (s).
            qdot_max: The speed to assume (rad/s or m/s); default the actuator's ``qdot_max``.

        Raises:
            ConfigurationError: no speed is given and the actuator has no ``qdot_max``.
        """
        v = _per_joint(qdot_max, "qdot_max", positive=True) if qdot_max is not None else None
        v = self.qdot_max if v is None else v
        if v is None:
            raise ConfigurationError(
                "stopping_distance needs a speed: give qdot_max or build the actuator with one",
                argument="qdot_max",
            )
        d = v * (self.delay_steps * float(period))
        if self.tau is not None:
            d = d + v * self.tau
        if self.qddot_max is not None:
            d = d + v * v / (2.0 * self.qddot_max)
        return np.asarray(np.broadcast_to(d, (self._n,)) if self._n else d, dtype=float).copy()

    def _broadcast(self, value: FloatArray | None, name: str) -> FloatArray | None:
        if value is None or value.ndim == 0:
            return value
        if value.shape[0] != self._n:
            raise ShapeError(
                f"actuator parameter {name} has {value.shape[0]} values but the robot has "
                f"{self._n} joints; give one value or one per joint",
                argument=name,
            )
        return value

    # -- simulation ----------------------------------------------------------------------------

    def reset(self, q0: ArrayLike) -> None:
        """Start at rest at ``q0`` (n,): zero velocity, an empty delay line, noise re-seeded.

        Raises:
            ShapeError: ``q0`` is not a finite vector, or a per-joint parameter has another length.
        """
        q = as_vector(q0, "q0")
        self._n = int(q.shape[0])
        for name in ("tau", "qdot_max", "qddot_max", "encoder_resolution", "encoder_noise_std"):
            self._broadcast(getattr(self, name), name)
        self._v = np.zeros(self._n)
        self._queue = collections.deque(np.zeros(self._n) for _ in range(self.delay_steps))
        self._rng = np.random.default_rng(self.seed)

    def flush(self) -> None:
        """Drop the commands still in the delay line (a stop reaches the drive at once)."""
        self._queue = collections.deque(np.zeros(self._n) for _ in range(self.delay_steps))

    def step(self, q: ArrayLike, qdot_cmd: ArrayLike, dt: float) -> tuple[FloatArray, FloatArray]:
        """Advance one period of ``dt`` seconds under the command ``qdot_cmd`` (n,).

        Args:
            q: (n,) true joint positions at the start of the period (m or rad).
            qdot_cmd: (n,) commanded joint velocities (rad/s or m/s), held over the period.
            dt: The period (s), > 0; the delay counts in these periods.

        Returns:
            ``(q_next, qdot_actual)``: the true positions at the end of the period and the
            actual joint velocities then (both (n,)).

        Raises:
            ShapeError: ``q`` or ``qdot_cmd`` is not a finite (n,) vector (call :meth:`reset`
                first).
            ConfigurationError: ``dt`` is not positive.
        """
        if self._n == 0:
            raise ShapeError("call ActuatorModel.reset(q0) before step()", argument="q0")
        qa = as_vector(q, "q", self._n)
        u = as_vector(qdot_cmd, "qdot_cmd", self._n)
        if not (math.isfinite(dt) and dt > 0.0):
            raise ConfigurationError(f"dt must be a positive period (s), got {dt!r}", argument="dt")
        if self.delay_steps:
            self._queue.append(u.copy())
            u = self._queue.popleft()
        if self.qdot_max is not None:
            u = np.clip(u, -self.qdot_max, self.qdot_max)
        v = self._v
        if self._lagged:
            assert self.tau is not None
            tau = np.broadcast_to(self.tau, (self._n,))
            lag = tau > 0.0
            safe = np.where(lag, tau, 1.0)
            decay = np.where(lag, np.exp(-dt / safe), 0.0)
            v_next = np.where(lag, u + (v - u) * decay, u)
            v_mean = np.where(lag, u + (v - u) * (safe / dt) * (1.0 - decay), u)
        else:
            v_next, v_mean = u, u
        if self.qddot_max is not None:
            dv_max = self.qddot_max * dt
            dv = v_next - v
            ramp = np.abs(dv) > dv_max
            if np.any(ramp):
                v_next = np.where(ramp, v + np.clip(dv, -dv_max, dv_max), v_next)
                v_mean = np.where(ramp, 0.5 * (v + v_next), v_mean)
        self._v = np.array(v_next, dtype=float)
        return qa + v_mean * dt, self._v.copy()

    def encoder(self, q: ArrayLike) -> FloatArray:
        """Return the encoder reading of the true positions ``q`` (n,): noise, then rounding to
        a multiple of ``encoder_resolution`` (rad or m). Exact when both are off."""
        qa = np.array(as_vector(q, "q"), dtype=float)
        if self._noisy:
            assert self.encoder_noise_std is not None
            qa = qa + self._rng.normal(0.0, 1.0, qa.shape[0]) * self.encoder_noise_std
        if self.encoder_resolution is not None:
            qa = np.round(qa / self.encoder_resolution) * self.encoder_resolution
        return qa

    def __repr__(self) -> str:
        def fmt(v: FloatArray | None) -> str:
            return "None" if v is None else repr(v.tolist())

        return (
            f"ActuatorModel(tau={fmt(self.tau)}, delay_steps={self.delay_steps}, "
            f"qdot_max={fmt(self.qdot_max)}, qddot_max={fmt(self.qddot_max)}, "
            f"encoder_resolution={fmt(self.encoder_resolution)}, "
            f"encoder_noise_std={fmt(self.encoder_noise_std)}, seed={self.seed!r})"
        )
