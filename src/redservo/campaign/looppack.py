"""What the compiled campaign loop covers, and the packs it takes (docs/scaling.md).

:func:`robot_reason` and :func:`scene_reason` say why an experiment's robot or task is not
covered by :func:`redservo.campaign.loop_kernel.closed_loop` (None: it is);
:func:`robot_args`, :func:`scene_args` and :func:`task_args` pack a covered experiment
into the tuples of plain arrays and numbers the loop takes (layouts:
:mod:`redservo.campaign.loop_kernel` for the robot, :mod:`redservo.kernels.loop_task` for
the scene and the task).
"""

from __future__ import annotations

from typing import Any

from redservo.binding.packs import scene_pack, scene_targets, task_pack
from redservo.experiment.build import Experiment

__all__ = [
    "robot_args",
    "robot_reason",
    "scene_args",
    "scene_reason",
    "search_scene_args",
    "task_args",
]


def robot_reason(exp: Experiment) -> str | None:
    """Why the loop has no kinematics for ``exp``'s robot (None: it has)."""
    if exp.robot.kernel_pack() is None:
        return f"robot {type(exp.robot).__name__}: no compiled kinematics in the loop"
    return None


def scene_reason(exp: Experiment) -> str | None:
    """Why the loop cannot measure ``exp``'s task (None: it can)."""
    from redservo.features import PointFeature
    from redservo.features.moments import MomentFeatures
    from redservo.scene import PointSet, Static, Waypoints

    if exp.task.depth != "current":
        return f"depth = {exp.task.depth!r} (the compiled loop uses the current depth)"
    for term in exp.task.terms:
        if type(term.feature) not in (PointFeature, MomentFeatures):
            return (
                f"feature {type(term.feature).__name__}: only image points and moments are compiled"
            )
        obj = exp.scene.object(term.target)
        if not isinstance(obj, PointSet) or type(obj.trajectory) not in (Static, Waypoints):
            return f"object {term.target!r}: only point sets, static or on waypoints, are compiled"
    return None


def robot_args(exp: Experiment) -> tuple[Any, ...]:
    """The robot pack of :mod:`redservo.robots.pack` (the robot packs itself)."""
    pack = exp.robot.kernel_pack()
    if pack is None:  # robot_reason said so first
        raise ValueError(f"robot {type(exp.robot).__name__} has no compiled kinematics")
    return pack


def _targets(exp: Experiment) -> list[str]:
    """The task's targets, in the order of the scene pack (sorted names)."""
    return scene_targets(exp.task)


def scene_args(exp: Experiment) -> tuple[Any, ...]:
    """The scene pack of :mod:`redservo.kernels.loop_task` (:func:`redservo.binding.packs.scene_pack`)."""
    opt = exp.options
    return scene_pack(exp.scene, exp.task, exp.camera, opt.image_margin_px, bool(opt.check_image))


def task_args(exp: Experiment) -> tuple[Any, ...]:
    """The task pack of :mod:`redservo.kernels.loop_task` (:func:`redservo.binding.packs.task_pack`)."""
    return task_pack(exp.task, float(exp.options.depth_scale))


def search_scene_args(exp: Experiment) -> tuple[Any, ...]:
    """:func:`scene_args` with the image check off: the reachability search's scene (the
    task error alone, :mod:`redservo.kernels.reach`)."""
    scene = scene_args(exp)
    return (*scene[:5], False, *scene[6:])
