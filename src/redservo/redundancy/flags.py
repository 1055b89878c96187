"""Typed diagnostic flags: what a control law did that a robot program should know about.

Every law reports unusual events as :class:`Event` records, a :class:`Flag` with a number
attached (its meaning is listed with each flag) and a human-readable message. The
simulator logs the numbers per step (one column per flag, NaN when the flag was not
raised), ``redservo run`` prints one warning line per flag with the first iteration and
the count, and campaign tables count the runs in which each occurred.
"""

from __future__ import annotations

import enum
from typing import NamedTuple

from redservo.kernels import flagbits as _bits

__all__ = ["FLAGS", "Event", "Flag"]


class Flag(enum.Enum):
    """The kinds of events a law reports. The value attached to each is given in brackets."""

    RANK_LOSS = "rank-loss"
    """``J1`` is rank-deficient; the truncated pseudo-inverse was used [rank deficiency m - r]."""
    NO_REDUNDANCY = "no-redundancy"
    """``rank J1 = n``: no null space, the law reduces to the classical one [n]."""
    ILL_CONDITIONED = "ill-conditioned"
    """A matrix the law inverts is ill-conditioned [amplification 1/σ_min it implies]."""
    DAMPED = "damped"
    """The robust inverse filtered small singular values [the amplification bound used]."""
    OVERCONSTRAINED = "more-constraints-than-redundancy"
    """More constrained axes than available redundancy [excess count]."""
    LEAST_SQUARES = "least-squares"
    """Constraints met only in the least-squares sense [number of levels affected]."""
    AXES_NOT_HANDLED = "axes-not-handled"
    """Critical axes the law does not act on (``gpm-auto`` stops one) [count]."""
    GAIN_ADJUSTED = "gain-adjusted"
    """A computed secondary gain was undefined, negative or capped [the gain used]."""
    TASK_SCALED = "task-scaled"
    """The main task was executed only in part (``sns``, ``qp``) [task scale or residual]."""
    SOLVER_FALLBACK = "solver-fallback"
    """The optimization solver failed and a fallback was used [1]."""
    BOUNDS_CONFLICT = "bounds-conflict"
    """Joint bounds are inconsistent; the velocity limit won [number of joints]."""
    NO_SECONDARY = "no-secondary"
    """No secondary command to project (``directional``) [0]."""
    VELOCITY_SCALED = "velocity-scaled"
    """The command was scaled down to respect the velocity limits [scale factor in (0, 1)]."""
    ACCELERATION_LIMITED = "acceleration-limited"
    """The command was scaled or moved to respect the acceleration limits [scale factor]."""
    ACCELERATION_EXCEEDED = "acceleration-exceeded"
    """The acceleration limit could not be kept without breaking a velocity or position
    limit; those won [largest excess, rad/s² or m/s²]."""
    SHIELD_ACTED = "shield-acted"
    """The position shield changed the command [largest change |Δq̇|, rad/s or m/s]."""
    NON_FINITE_REPLACED = "non-finite-replaced"
    """The law produced NaN or inf; the safe fallback command was sent [number of entries]."""
    POSITION_LIMIT_UNAVOIDABLE = "position-limit-unavoidable"
    """The command takes a joint past its hard limit (``q + dt q̇`` outside
    ``[q̄_min, q̄_max]``) because no command within the limits that outrank the position
    could keep it inside: the rate limits with the shield off (a previous command too fast
    to stop within ``q̈_max dt``), the velocity limit with it on. The message names the joint
    [largest distance past the hard limit, rad or m]."""
    HORIZON_INFEASIBLE = "horizon-infeasible"
    """``predictive``: no command sequence over the horizon meets every constraint (joint
    limits with the margin, visibility); the fallback law's command was used [solver exit code]."""
    SOLVER_ITERATIONS = "solver-iterations"
    """``predictive``: the QP solver hit its iteration limit (or the solve its time budget);
    the fallback law's command was used [iterations, or the solve time in s]."""
    CAMERA_MOTION_LIMITED = "camera-motion-limited"
    """The camera-motion limit (:class:`redservo.control.ImageMotionLimit`) scaled the command
    down so that no image point moves further between two frames than the tracker follows,
    nor smears more than the detector tolerates [the scale, in (0, 1)]."""
    DISTANCE_SHIELD = "distance-shield-acted"
    """The distance shield (:mod:`redservo.control.avoidance`) scaled the command so that no
    collision pair comes closer than ``d_safe`` within one period [the scale in [0, 1)]."""
    NO_POSE = "no-pose"
    """A frame's tracked dots gave no pose of the target (PnP, :mod:`redservo.vision.pnp`:
    too few detected dots, or no pose within the reprojection tolerance). Raised by the
    ``predictive`` law's own PnP (its model used its estimate from the features instead) and
    by the image sensor's ``depth = "pose"`` (:mod:`redservo.sensors.flags`: the interaction
    matrices kept the depths of the last pose, the desired ones before the first); the
    message says which [frames in a row without a pose]."""

    @property
    def label(self) -> str:
        """The flag's name as printed and used in log columns (``flag.<label>``)."""
        return self.value


def _kernel_order() -> tuple[Flag, ...]:
    """The flags in the kernels' numbering (:mod:`redservo.kernels.flagbits`), checked."""
    order = tuple(sorted(Flag, key=lambda f: int(getattr(_bits, f.name))))
    if [getattr(_bits, f.name) for f in order] != list(range(_bits.N_FLAGS)):
        raise RuntimeError("redservo.kernels.flagbits does not number every Flag once")
    return order


FLAGS: tuple[Flag, ...] = _kernel_order()
"""Every flag, in the kernels' order: flag ``FLAGS[j]`` is bit ``1 << j`` of a kernel's event
mask (:mod:`redservo.kernels.events`); log columns follow it."""


class Event(NamedTuple):
    """One flag raised by one law call."""

    flag: Flag
    value: float
    message: str
