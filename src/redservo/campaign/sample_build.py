"""A campaign sample's experiment, built from what changes: the parts every sample shares once.

A sample (:func:`redservo.campaign.sampling.draw_built`) differs from the campaign's base
scenario only in ``robot.q0``, the objects' poses and motions and the ``[simulation]``
noise, depth and hand-eye keys (:mod:`redservo.campaign`, "Target placement"). So the
robot with its limits, the camera and the scenario's law, built from the base scenario,
are the sample's own; :func:`sample_experiment` builds them once per campaign definition
(per thread) and hands them to :func:`redservo.experiment.build.build` (``shared=``), which
builds the rest as for any scenario: the start ``q0`` checked against the limits, the scene,
the task, the options, the sensor, actuator, obstacles, collision set-up and camera timing,
and the start check. The result is ``build(sc)``'s experiment
(tests/test_campaign_bulk.py compares them field by field on shipped campaigns; the rows
are the same byte for byte), at about two thirds of its cost.

A set-up outside this (a camera on the world, whose robot carries the objects; a MuJoCo
simulator) is built by :func:`~redservo.experiment.build.build` itself.

The shared robot, limits, camera and law are read, never changed, by a campaign's runs:
each run makes its own law (``Experiment.run(method=...)``), the compiled loop packs them.
"""

from __future__ import annotations

import threading
import weakref
from typing import TYPE_CHECKING, Any

from redservo.campaign.definition import CampaignDefinition
from redservo.scenario import Scenario

if TYPE_CHECKING:
    from redservo.experiment.build import SharedParts

__all__ = ["sample_experiment"]

_PARTS = threading.local()
"""Per thread: ``(weakref to the definition, its shared parts or None)``."""


def _shared(defn: CampaignDefinition) -> SharedParts | None:
    """The shared parts of ``defn``'s samples, or None when :func:`build` must build them
    (module docstring); cached per thread for the last definition."""
    last = getattr(_PARTS, "last", None)
    if last is not None and last[0]() is defn:
        out: SharedParts | None = last[1]
        return out
    out = _build_shared(defn.scenario)
    _PARTS.last = (weakref.ref(defn), out)
    return out


def _build_shared(sc: Scenario) -> SharedParts | None:
    from redservo.experiment.build import SharedParts, _limits, scenario_law
    from redservo.experiment.camera import scenario_camera
    from redservo.experiment.robot import scenario_robot

    spec = sc.spec
    if spec.camera.mount != "hand" or spec.simulator is not None:
        return None
    robot = scenario_robot(sc, spec)
    limits = _limits(sc, spec, robot)
    return SharedParts(robot, limits, scenario_law(spec), scenario_camera(sc))


def sample_experiment(defn: CampaignDefinition, sc: Scenario) -> Any:
    """The :class:`~redservo.experiment.build.Experiment` of ``defn``'s sample scenario
    ``sc``: ``build(sc)``'s, the shared parts built once (module docstring).

    Raises:
        ScenarioError: as :func:`~redservo.experiment.build.build` (names the key).
    """
    from redservo.experiment.build import build

    parts = _shared(defn)
    if parts is None:
        return build(sc)
    return _per_sample(sc, parts)


def _per_sample(sc: Scenario, parts: SharedParts) -> Any:
    """``build(sc)`` with the robot, its limits, the law and the camera of ``parts``."""
    from redservo.experiment.build import build

    return build(sc, shared=parts)
