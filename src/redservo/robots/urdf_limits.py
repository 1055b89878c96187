"""The rate limits of a URDF robot: from the file, or from the caller, never silently lost.

For each servoed joint, the velocity limit is the caller's ``qdot_max`` when given for it,
else the file's ``<limit velocity>``, which must then be a number in
``(0, VELOCITY_BOUND]`` (rad/s for a revolute or continuous joint, m/s for a prismatic
one). A missing, zero, negative, non-finite or absurd velocity in the file is an error
naming the file and the joint, never a robot without velocity limits.

Acceleration limits work the same way with ``qddot_max`` and redservo's extension
``<redservo:limit acceleration="..."/>`` (:data:`~redservo.robots.urdf_values.REDSERVO_NS`),
bounded by ``ACCELERATION_BOUND``, with one difference: URDF has no acceleration limit,
so a file that gives none for any servoed joint yields ``qddot_max = None`` (give them
with ``qddot_max=``); a file that gives some but not all is an error.

The caller's value is a scalar (every joint), one value per servoed joint (the file's
values are then all ignored), or a mapping ``{joint name: value}`` (only those joints).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Final

import numpy as np
from numpy.typing import ArrayLike

from redservo.errors import ConfigurationError, UnknownNameError
from redservo.robots.urdf_parse import URDFJoint

__all__ = ["ACCELERATION_BOUND", "VELOCITY_BOUND", "rate_limits"]

VELOCITY_BOUND: Final = {"revolute": 100.0, "continuous": 100.0, "prismatic": 10.0}
"""Largest velocity limit (rad/s, rad/s, m/s) accepted from a file, by joint type."""
ACCELERATION_BOUND: Final = {"revolute": 1000.0, "continuous": 1000.0, "prismatic": 100.0}
"""Largest acceleration limit (rad/s², rad/s², m/s²) accepted from a file, by joint type."""

RateLimit = ArrayLike | Mapping[str, float] | None
"""What a caller gives: None (the file's), a scalar, (n,) values or ``{joint: value}``."""


def _unit(j: URDFJoint, accel: bool) -> str:
    base = "m/s" if j.kind == "prismatic" else "rad/s"
    return base + "²" if accel else base


def _named(
    given: Mapping[str, float], argument: str, servo: Sequence[URDFJoint]
) -> dict[str, float]:
    """Check a ``{joint name: value}`` override: servoed names, finite numbers > 0."""
    names = [j.name for j in servo]
    out: dict[str, float] = {}
    for name, value in given.items():
        if name not in names:
            raise UnknownNameError(
                f"{argument}: {name!r} is not a servoed joint; the servoed joints are: "
                f"{', '.join(names)}",
                argument=argument,
            )
        ok = not isinstance(value, bool) and isinstance(value, int | float | np.number)
        if not ok or not (math.isfinite(float(value)) and float(value) > 0.0):
            raise ConfigurationError(
                f"{argument}[{name!r}] must be a finite number > 0, got {value!r}",
                argument=argument,
            )
        out[name] = float(value)
    return out


def _from_file(j: URDFJoint, accel: bool, source: str, argument: str) -> float | None:
    """The joint's rate limit as written in the file, checked (None when absent)."""
    text = j.acceleration_text if accel else j.velocity_text
    value = j.acceleration if accel else j.velocity
    if text is None or value is None:
        return None
    bound = (ACCELERATION_BOUND if accel else VELOCITY_BOUND)[j.kind]
    if math.isfinite(value) and 0.0 < value <= bound:
        return value
    element = '<redservo:limit acceleration="' if accel else '<limit velocity="'
    kind = "an acceleration" if accel else "a velocity"
    raise ConfigurationError(
        f'URDF {source}: joint {j.name!r} ({j.kind}) has {element}{text}">; {kind} limit '
        f"must be a number in (0, {bound:g}] {_unit(j, accel)}: fix the file, or give "
        f"{argument} for this joint (in a scenario: [robot] {argument}, one value for all "
        "joints or one per joint)",
        argument="path",
    )


def _resolve(
    given: RateLimit, accel: bool, source: str, servo: Sequence[URDFJoint]
) -> ArrayLike | None:
    argument = "qddot_max" if accel else "qdot_max"
    if given is not None and not isinstance(given, Mapping):
        return given  # every joint from the caller (checked by JointLimits)
    override = {} if given is None else _named(given, argument, servo)
    values: list[float] = []
    missing: list[URDFJoint] = []
    for j in servo:
        value = override.get(j.name)
        if value is None:
            value = _from_file(j, accel, source, argument)
        if value is None:
            missing.append(j)
        else:
            values.append(value)
    if not missing:
        return np.array(values)
    if accel and len(missing) == len(servo):
        return None  # URDF has no acceleration limit: none anywhere means none given
    names = ", ".join(repr(j.name) for j in missing)
    element = "<redservo:limit acceleration>" if accel else "<limit velocity>"
    what = "an acceleration" if accel else "a velocity"
    bounds = "(0, 1000] rad/s² or (0, 100] m/s²" if accel else "(0, 100] rad/s or (0, 10] m/s"
    raise ConfigurationError(
        f"URDF {source}: joint(s) {names} have no {element}; redservo needs {what} limit for "
        f"every servoed joint ({bounds}): add it to the file, or give {argument} (in a "
        f"scenario: [robot] {argument}, one value per joint)",
        argument="path",
    )


def rate_limits(
    source: str, servo: Sequence[URDFJoint], qdot_max: RateLimit, qddot_max: RateLimit
) -> tuple[ArrayLike, ArrayLike | None]:
    """Return ``(qdot_max, qddot_max)`` for the servoed joints (module docstring).

    Args:
        source: The file name, for messages.
        servo: The servoed joints, in ``q`` order.
        qdot_max: The caller's velocity limits (rad/s or m/s), see :data:`RateLimit`.
        qddot_max: The caller's acceleration limits (rad/s² or m/s²), see :data:`RateLimit`.

    Raises:
        ConfigurationError: a rate the file gives (and the caller does not replace) is
            missing, not a number, not > 0 or beyond its bound; a ``{joint: value}``
            value is not a finite number > 0.
        UnknownNameError: a ``{joint: value}`` key is not a servoed joint.
    """
    qdot = _resolve(qdot_max, False, source, servo)
    assert qdot is not None  # velocity limits are required
    return qdot, _resolve(qddot_max, True, source, servo)
