"""MC05 §V-A with the limited axis along the optical axis: which feature the avoidance speeds up.

In ``mc05-joint-limits`` the limited gantry axis (x) moves the camera mostly along the
camera's y axis, so the directional operator speeds up ``yn`` as much as ``an``; MC05 Fig. 4
shows the depth feature (and ``xg``) modified and ``sy`` not. Which feature is accelerated
depends on the direction in which the limited axis moves the camera: for ``an`` to lead, that
axis must move the camera along its optical axis.

This experiment is the same task (same dots, same desired pose, runs and checks as
:mod:`~redservo.reproduction.mc05_joint_limits`) on a start where the camera looks along the
gantry's z axis (axis 3; ``|z_c · z_base| > 0.92``) and where the classical path first moves
z *away* from its goal before coming back: the z range is narrowed so that this backward
excursion crosses the lower limit while the goal stays inside. The joint-limit force then
pushes z forward, along the optical axis and in the direction the task asks for, so the
directional projector lets it through and ``an`` converges faster.

MC05 shows a non-convex joint domain (its Fig. 2). A :class:`~redservo.limits.JointLimits`
domain is a box (one interval per axis) and the Afma6's is too, so the domain here is a box;
a non-convex domain would need coupled joint constraints, which no law of the papers handles.

The start and the target come from a throwaway random search (start within ±0.6 of
mid-range normalized, wrist tilt B in [0, 0.4] rad with the optical axis within 23° of the
gantry's z, target 0.5-0.85 m away, tilted 0.1-0.6 rad and turned up to 1.45 rad; kept: the
unlimited classical law converges, z moves at least 1.5 cm away from its goal over at least
5 iterations at below 0.15 m/s, that excursion is at least a fifth of z's net motion, and the
goal lies inside the Afma6's z range). The z range is then narrowed to the 0.1 m slice
[-0.1126, -0.0126] m: the start at -0.76 normalized (just outside the lower band), the
excursion 3.8 mm past the lower limit, the goal at -0.53. Looking along z needs B close to
0, which is near B's lower limit (-0.1 rad): B starts in its band too (-0.91 normalized),
as it would on the real Afma6.
"""

from __future__ import annotations

from redservo.reproduction.base import ExperimentSpec
from redservo.reproduction.mc05_joint_limits import joint_limit_experiment

__all__ = ["EXPERIMENTS", "OPTICAL_AXIS_OVERRIDES"]

OPTICAL_AXIS_OVERRIDES: tuple[str, ...] = (
    "robot.q0=[0.1091, 0.0847, -0.1006, 0.6734, 0.0161, 0.1662]",
    "robot.q_min=[-0.6501, -0.6001, -0.1126, -2.7301, -0.1001, -1.5901]",
    "robot.q_max=[0.7001, 0.5201, -0.0126, 2.7301, 2.4801, 1.5901]",
    "objects[0].pose_in_camera={ translation = [0.0855, 0.0910, 0.6205], "
    "rotvec = [0.0035, -0.1288, 0.4746] }",
)
"""Overrides of ``mc05-joint-limits`` for this experiment (start, z range, target)."""

NOTES = (
    "Same dots, desired pose, λ = 0.5 1/s, dt = 40 ms and κ = 10 as `mc05-joint-limits`; the "
    "start and the target pose come from a random search (module docstring) for a case "
    "where the camera looks along the gantry's z axis and the classical path moves z away "
    "from its goal before coming back (its axis 3 moves the camera along (-0.16, 0.03, 0.99) "
    "in the camera frame). The z axis is narrowed to a 0.1 m slice so that this excursion "
    "crosses its lower limit (classical hits it at iteration 14) while the goal stays "
    "inside; the other axes keep the ViSP 3.5 limits (B, near 0 to look along z, starts "
    "in its band, as it would on the real robot). The joint domain is a box (MC05's Fig. 2 "
    "shows a non-convex one, which per-axis joint limits cannot describe)."
)

EXPERIMENTS: tuple[ExperimentSpec, ...] = (
    joint_limit_experiment(
        "mc05-optical-axis",
        title="MC05 §V-A — the limited axis moves the camera along its optical axis (Figs. 2-4)",
        scenario="mc05-joint-limits",
        notes=NOTES,
        base_overrides=OPTICAL_AXIS_OVERRIDES,
        plane=(2, 0),
        variant_of="mc05-joint-limits",
    ),
)
