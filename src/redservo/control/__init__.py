"""The control core: :class:`Controller`, the one object every closed loop drives.

* :mod:`redservo.control.controller`: :class:`Controller` (measurement -> task -> objectives
  -> feed-forward -> law -> saturation); :mod:`redservo.control.steps`: what it takes and
  returns; :mod:`redservo.control.checks`: the checks of its arguments;
* :mod:`redservo.control.objectives`: the composable secondary objectives;
* :mod:`redservo.control.feedforward`: the feed-forward term of a moving target;
* :mod:`redservo.control.image_motion`: the camera-motion limit (:class:`ImageMotionLimit`).

It sits above the public objects (robots, task, laws, scene) and below the loops
(``simulation/``, ``hardware/``), which supply only time, measurements and actuation.
"""

from __future__ import annotations

from redservo.control.controller import Controller
from redservo.control.feedforward import FEEDFORWARD_MODES, Feedforward
from redservo.control.image_motion import ImageMotionLimit
from redservo.control.objectives import (
    CallableObjective,
    JointLimitForce,
    Objective,
    ObjectiveContext,
    Occlusion,
    OcclusionAvoidance,
)
from redservo.control.steps import ControlStep, Features, Measurement, SceneContext

__all__ = [
    "FEEDFORWARD_MODES",
    "CallableObjective",
    "ControlStep",
    "Controller",
    "Features",
    "Feedforward",
    "ImageMotionLimit",
    "JointLimitForce",
    "Measurement",
    "Objective",
    "ObjectiveContext",
    "Occlusion",
    "OcclusionAvoidance",
    "SceneContext",
]
