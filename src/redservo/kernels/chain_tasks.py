"""Image-point task and whole step on a generic chain (URDF robots): kernels of
:mod:`redservo.kernels.chain` with the task and law of :mod:`redservo.kernels.tasks`.

The counterparts of ``dh_points``/``dh_step`` there, with the chain packed as
:mod:`redservo.kernels.chain` describes (``frames``, ``joints``) in place of a DH table;
the output buffer ``out`` has the layout of :func:`redservo.kernels.tasks.output_size`.
A module of its own so that the chain kinematics (called alone by every URDF robot) does
not share a cache stamp with the laws.
"""

from __future__ import annotations

from typing import Any

from redservo.kernels._jit import kernel
from redservo.kernels.chain import chain_kinematics
from redservo.kernels.tasks import _after_task, points_task

__all__ = ["chain_points", "chain_step"]


@kernel
def chain_points(q: Any, robot: Any, task: Any) -> Any:
    """``(e1, J1)`` of an image-point task (current depth) on a chain (``robot``:
    ``(frames, joints, eMc, cVe)``; ``task``: ``(bMo, pts, s_star, C)``)."""
    frames, joints, eMc, cVe = robot
    bMo, pts, s_star, C = task
    bMc, J = chain_kinematics(q, frames, joints, eMc, cVe)
    e1, J1, _, _ = points_task(bMc, J, bMo, pts, s_star, C)
    return e1, J1


@kernel
def chain_step(
    q: Any,
    robot: Any,
    task: Any,
    law: Any,
    limits: Any,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
    out: Any,
) -> None:
    """A full image-point step on a chain: kinematics, features, ``J1``, law, safety."""
    e1, J1 = chain_points(q, robot, task)
    _after_task(e1, J1, q, law, limits, lam, dt, prev, has_prev, out)
