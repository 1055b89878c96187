"""A campaign sample's experiment, built from what changes: the parts every sample shares once.

A sample (:func:`redservo.campaign.sampling.draw_built`) differs from the campaign's base
scenario only in ``robot.q0``, the objects' poses and motions and the ``[simulation]``
noise, depth and hand-eye keys (:mod:`redservo.campaign`, "Target placement"). So the
robot with its limits, the camera and the scenario's law, built from the base scenario,
are the sample's own; :func:`sample_experiment` builds them once per campaign definition
(per thread) and builds per sample, with :func:`redservo.experiment.build.build`'s own
steps and in its order, the rest: the start ``q0`` checked against the limits, the scene,
the task, the options, the sensor, actuator, obstacles, collision set-up and camera timing,
and the start check. The result is :func:`~redservo.experiment.build.build`'s experiment
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
from typing import Any, NamedTuple

from redservo.campaign.definition import CampaignDefinition
from redservo.scenario import Scenario

__all__ = ["sample_experiment"]

_PARTS = threading.local()
"""Per thread: ``(weakref to the definition, its shared parts or None)``."""


class _Shared(NamedTuple):
    """The parts of a sample's experiment that are the base scenario's."""

    robot: Any
    limits: Any
    camera: Any
    law: Any


def _shared(defn: CampaignDefinition) -> _Shared | None:
    """The shared parts of ``defn``'s samples, or None when :func:`build` must build them
    (module docstring); cached per thread for the last definition."""
    last = getattr(_PARTS, "last", None)
    if last is not None and last[0]() is defn:
        out: _Shared | None = last[1]
        return out
    out = _build_shared(defn.scenario)
    _PARTS.last = (weakref.ref(defn), out)
    return out


def _build_shared(sc: Scenario) -> _Shared | None:
    from redservo.experiment.build import _limits
    from redservo.experiment.camera import scenario_camera
    from redservo.experiment.robot import scenario_robot
    from redservo.redundancy import make_law

    spec = sc.spec
    if spec.camera.mount != "hand" or spec.simulator is not None:
        return None
    robot = scenario_robot(sc, spec)
    limits = _limits(sc, spec, robot)
    ctl = spec.control
    law = make_law(
        ctl.method, shield=ctl.shield, robust=ctl.robust, scaling=ctl.scaling, **ctl.options
    )
    return _Shared(robot, limits, scenario_camera(sc), law)


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


def _per_sample(sc: Scenario, parts: _Shared) -> Any:
    """``build(sc)``'s steps after the robot, its limits, the law and the camera."""
    from redservo.experiment.build import (
        Experiment,
        _actuator,
        _options,
        _scene,
        _start,
        _task,
    )
    from redservo.experiment.camera import mounted_robot
    from redservo.experiment.sensor import attach_timing, scenario_sensor
    from redservo.experiment.start import attach_collision, check_start

    spec = sc.spec
    robot = mounted_robot(sc, parts.robot)  # the robot itself (a camera on the hand)
    limits, camera = parts.limits, parts.camera
    q0 = _start(sc, spec, robot, limits)
    scene = _scene(sc, spec, robot, q0)
    task = _task(sc, spec, scene)
    options = _options(sc, spec, robot, camera)
    exp = Experiment(sc, robot, scene, task, parts.law, q0, limits, options, camera)
    exp.sensor = scenario_sensor(sc, camera)
    exp.actuator = _actuator(sc, spec, robot.n)
    exp.obstacles = tuple(o.obstacle() for o in spec.obstacles)
    attach_collision(sc, exp)
    attach_timing(sc, exp)
    check_start(sc, spec, exp)
    return exp
