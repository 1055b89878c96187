"""The checks of a :class:`~redservo.control.Controller`'s arguments: each bad one raises one
error from :mod:`redservo.errors` whose ``argument`` names it."""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.control.feedforward import FEEDFORWARD_MODES
from redservo.errors import ConfigurationError, ShapeError
from redservo.limits import JointLimits
from redservo.redundancy.gain import AdaptiveGain
from redservo.robots.base import Robot
from redservo.task import VisualTask

__all__ = ["LAW_KEYWORDS", "check_controller", "law_keywords", "saturation"]

REQUIRED = ("J1", "e1", "q", "limits", "lam", "dt")
LAW_KEYWORDS = (*REQUIRED, "de1_dt", "secondary", "qdot_prev")
"""Every keyword a law may take; the first six are required."""


def law_keywords(law: Callable[..., Any]) -> frozenset[str]:
    """The keywords of :data:`LAW_KEYWORDS` that ``law`` accepts (all with ``**kwargs``)."""
    try:
        params = inspect.signature(law).parameters
    except (TypeError, ValueError):  # no signature (a builtin): assume the full interface
        return frozenset(LAW_KEYWORDS)
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return frozenset(LAW_KEYWORDS)
    return frozenset(n for n in LAW_KEYWORDS if n in params)


def finite_positive(value: object) -> bool:
    """True for a real number (not a bool) that is finite and > 0."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        return False
    return math.isfinite(float(value)) and float(value) > 0.0


def saturation(value: ArrayLike | None, n: int) -> FloatArray | None:
    """The output saturation (n,) in rad/s or m/s from a number or (n,), or None.

    Raises:
        ShapeError: not a number or (n,).
        ConfigurationError: not positive and finite.
    """
    if value is None:
        return None
    arr = np.asarray(value, dtype=float)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] != n):
        raise ShapeError(
            f"qdot_saturation must be a number or ({n},) (one per joint), got shape {arr.shape}",
            argument="qdot_saturation",
        )
    if not (np.all(np.isfinite(arr)) and np.all(arr > 0.0)):
        raise ConfigurationError(
            f"qdot_saturation must be positive and finite (rad/s or m/s), got {value!r}",
            argument="qdot_saturation",
        )
    return np.broadcast_to(arr, (n,)).copy()


def _check_parts(robot: object, task: object, law: object, limits: object) -> None:
    if not isinstance(robot, Robot):
        raise ConfigurationError(f"robot must be a Robot, got {robot!r}", argument="robot")
    if not isinstance(task, VisualTask):
        raise ConfigurationError(f"task must be a VisualTask, got {task!r}", argument="task")
    if not callable(law):
        raise ConfigurationError(
            f"law must be a control law (redservo.make_law) or a callable, got {law!r}",
            argument="law",
        )
    if limits is not None and (not isinstance(limits, JointLimits) or limits.n != robot.n):
        raise ShapeError(
            f"limits must be JointLimits for the robot's {robot.n} joints, got {limits!r}",
            argument="limits",
        )


def _check_numbers(lam: object, dt: object, feedforward: object, depth_scale: object) -> None:
    if not isinstance(lam, AdaptiveGain) and not finite_positive(lam):
        raise ConfigurationError(
            f"lam must be a finite positive gain (1/s) or an AdaptiveGain, got {lam!r}",
            argument="lam",
        )
    if not finite_positive(dt):
        raise ConfigurationError(
            f"dt must be a finite positive period (s), got {dt!r}", argument="dt"
        )
    if feedforward not in FEEDFORWARD_MODES:
        raise ConfigurationError(
            f"feedforward must be one of {FEEDFORWARD_MODES}, got {feedforward!r}",
            argument="feedforward",
        )
    if not finite_positive(depth_scale):
        raise ConfigurationError(
            f"depth_scale must be a finite positive factor, got {depth_scale!r}",
            argument="depth_scale",
        )


def _check_law_keywords(
    accepts: frozenset[str], objectives: Sequence[object], feedforward: str
) -> None:
    missing = [k for k in REQUIRED if k not in accepts]
    if missing:
        raise ConfigurationError(
            f"law must accept the keywords {', '.join(REQUIRED)}; it lacks {', '.join(missing)}",
            argument="law",
        )
    if objectives and "secondary" not in accepts:
        raise ConfigurationError(
            "objectives need a law that accepts the keyword 'secondary'", argument="objectives"
        )
    if feedforward != "none" and "de1_dt" not in accepts:
        raise ConfigurationError(
            f"feedforward={feedforward!r} needs a law that accepts the keyword 'de1_dt'",
            argument="feedforward",
        )


def check_controller(
    robot: object,
    task: object,
    law: Callable[..., Any],
    limits: object,
    *,
    lam: object,
    dt: object,
    objectives: Sequence[object],
    feedforward: str,
    depth_scale: object,
) -> frozenset[str]:
    """Check a controller's arguments; return the law's keywords (:func:`law_keywords`).

    Raises:
        ConfigurationError, ShapeError: one bad argument, named in the error's ``argument``.
    """
    _check_parts(robot, task, law, limits)
    _check_numbers(lam, dt, feedforward, depth_scale)
    for i, obj in enumerate(objectives):
        if not callable(obj):
            raise ConfigurationError(
                f"objectives[{i}] must be an objective (callable with an ObjectiveContext), "
                f"got {obj!r}",
                argument=f"objectives[{i}]",
            )
    accepts = law_keywords(law)
    _check_law_keywords(accepts, objectives, feedforward)
    return accepts
