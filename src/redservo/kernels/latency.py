"""Latency compensation kernels: the command history's sum and the points brought to the
present (:mod:`redservo.control.latency`, whose module docstring gives the equation).

The history keeps its commands' times and camera twists ``J(q_k) q̇_k`` in a ring of
arrays (slot ``(head + i) % cap`` holds the ``i``-th command, oldest first):
:func:`motion` sums ``twist_k · |[t_k, t_k + T) ∩ [stamp, now)|`` over the commands that
may overlap, in the order and with the roundings of the Python loop it replaces (one
product, then one sum, per term: no fused multiply-add), and names the commands whose
twist is still to be computed (:func:`robot_twist` computes one from the robot's compiled
kinematics, else the robot object's Jacobian does, in Python).
:func:`present_points` is ``s + L(s, 1/Ẑ) · motion`` for a task of image points, ``L``
from :func:`~redservo.kernels.features.points_interaction` as the compiled control step
builds it, the product by BLAS as numpy's ``@``. Units: seconds; the twist in m/s and
rad/s; normalized image units; inverse depths in 1/m.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.features import points_interaction
from redservo.kernels.robot import robot_kinematics

__all__ = ["first_after", "motion", "present_points", "robot_motion", "robot_twist"]


@kernel
def first_after(
    t: Any, head: int, count: int, period: float, stamp: float, eps: float, ordered: bool
) -> int:
    """The first command (0 to ``count``) that may end after ``stamp`` (s): those before
    it end by the stamp when the commands came in time order, found from the newest; 0
    when they did not (every command is looked at)."""
    if not ordered:
        return 0
    cap = t.shape[0]
    first = count
    while first > 0:
        if first < count:
            end = t[(head + first) % cap]
        else:
            end = t[(head + count - 1) % cap] + period
        if end <= stamp + eps:
            break
        first -= 1
    return first


@kernel
def motion(
    t: Any,
    twist: Any,
    has: Any,
    ring: Any,
    period: float,
    stamp: float,
    now: float,
    eps: float,
) -> Any:
    """``(total (6,), missing)``: the sum of the module docstring over the commands of the
    ring ``(head, count, ordered)`` with an overlap above ``eps`` (s), and the commands
    (0 to count - 1, oldest first) among them whose twist ``has`` not been computed (the
    sum is then incomplete: the caller computes them and calls again)."""
    head, count, ordered = ring
    cap = t.shape[0]
    total = np.zeros(6)
    missing = np.empty(count, dtype=np.int64)
    nmiss = 0
    for i in range(first_after(t, head, count, period, stamp, eps, ordered), count):
        slot = (head + i) % cap
        end = t[(head + i + 1) % cap] if i + 1 < count else t[slot] + period
        overlap = min(end, now) - max(t[slot], stamp)
        if overlap <= eps:
            continue
        if not has[slot]:
            missing[nmiss] = i
            nmiss += 1
            continue
        for j in range(6):
            term = twist[slot, j] * overlap
            total[j] = total[j] + term
    return total, missing[:nmiss]


@kernel
def present_points(s: Any, iz: Any, shift: Any) -> Any:
    """``s + L(s, iz) · shift`` (k,): the points ``s`` (k,) with inverse depths ``iz``
    (k/2,) (1/m, through the task's depth option) moved by the camera displacement
    ``shift`` (6,) (m, rad), to first order."""
    return s + np.dot(points_interaction(s, iz), shift)


@kernel
def robot_twist(q: Any, qdot: Any, robot: Any) -> Any:
    """The camera twist ``J(q) q̇`` (6,) (m/s, rad/s) of the command ``qdot`` (n,) at ``q``
    (n,): ``J`` from the robot's compiled kinematics (``robot``, the pack of
    :mod:`redservo.robots.pack`: the robot object's ``jacobian``, bit for bit), the product
    by BLAS as numpy's ``@``."""
    return np.dot(robot_kinematics(q, robot)[1], qdot)


@kernel
def robot_motion(
    t: Any,
    twist: Any,
    has: Any,
    ring: Any,
    period: float,
    stamp: float,
    now: float,
    eps: float,
    q: Any,
    qdot: Any,
    robot: Any,
) -> Any:
    """:func:`motion`'s total (6,) in one call: the twists still missing computed by
    :func:`robot_twist` from the ring's joints ``q`` and commands ``qdot`` (cap, n) and kept
    in ``twist`` and ``has``, then the sum, as the caller did with :func:`motion`, the
    twists, and :func:`motion` again (the same numbers)."""
    total, missing = motion(t, twist, has, ring, period, stamp, now, eps)
    if missing.shape[0] == 0:
        return total
    head, cap = ring[0], t.shape[0]
    for k in range(missing.shape[0]):
        slot = (head + missing[k]) % cap
        tw = robot_twist(q[slot], qdot[slot], robot)
        for j in range(6):
            twist[slot, j] = tw[j]
        has[slot] = True
    return motion(t, twist, has, ring, period, stamp, now, eps)[0]
