"""The diagnostic flags as the kernels number them (no numba: importing this is free).

Flag ``j`` is bit ``1 << j`` of a kernel's event mask and entry ``j`` of its value and
source arrays (:mod:`redservo.kernels.events`). The order here *is* the order of
:data:`redservo.redundancy.flags.FLAGS` (the enum takes it from these names), so the log
columns, the campaign's flag counts and the kernels agree by construction.

A flag may be raised for more than one reason (a *source*, a bit of ``src[j]``); the
source chooses the message in :mod:`redservo.redundancy.messages`. Sources are numbered per
flag; ``ONLY`` is the single source of a flag that has one.
"""

from __future__ import annotations

__all__ = ["N_FLAGS"]

(
    RANK_LOSS,
    NO_REDUNDANCY,
    ILL_CONDITIONED,
    DAMPED,
    OVERCONSTRAINED,
    LEAST_SQUARES,
    AXES_NOT_HANDLED,
    GAIN_ADJUSTED,
    TASK_SCALED,
    SOLVER_FALLBACK,
    BOUNDS_CONFLICT,
    NO_SECONDARY,
    VELOCITY_SCALED,
    ACCELERATION_LIMITED,
    ACCELERATION_EXCEEDED,
    SHIELD_ACTED,
    NON_FINITE_REPLACED,
    POSITION_LIMIT_UNAVOIDABLE,
    HORIZON_INFEASIBLE,
    SOLVER_ITERATIONS,
    CAMERA_MOTION_LIMITED,
    DISTANCE_SHIELD,
    NO_POSE,
) = range(23)
N_FLAGS = 23

# -- sources (bits of src[flag]) -----------------------------------------------------------------
ONLY = 1
"""The one source of a flag raised for one reason only."""
BY_TASK, BY_DIRECTIONAL = 1, 2
"""RANK_LOSS: the truncated task inverse; ``directional``'s sub-threshold directions."""
NORED_TASK, NORED_WLN = 1, 2
"""NO_REDUNDANCY: the generic case; ``wln`` (the weights have no effect)."""
ILL_ROBUST, ILL_EXACT = 1, 2
"""ILL_CONDITIONED (iterative constraints): with the robust inverse, or exact."""
DAMPED_TASK, DAMPED_ALPHA, DAMPED_CONSTRAINTS, DAMPED_PII, DAMPED_WEIGHTED = 1, 2, 4, 8, 16
"""DAMPED: the task inverse; eq. 9's gain (gpm-auto); the constraint rows (iterative);
1/|P_ii| (large-projection); the weighted task inverse (wln)."""
LS_LEVELS, LS_WEIGHTED = 1, 2
"""LEAST_SQUARES: iterative levels; ``wln``'s weighted rank loss."""
GAIN_UNDEFINED, GAIN_NEGATIVE, GAIN_CAPPED = 1, 2, 4
"""GAIN_ADJUSTED (gpm-auto's α): undefined, negative, capped to ``alpha_max``."""
SCALED_SNS, SCALED_SNS_RESTORED, SCALED_QP = 1, 2, 4
"""TASK_SCALED: ``sns`` (its best scale restored or not); ``qp``'s task residual."""
ACC_RELEASED, ACC_KEPT_POSITION = 1, 2
"""ACCELERATION_EXCEEDED: released against the velocity/position limits; exceeded to keep
the position limit."""
BY_ITERATIONS, BY_TIME_BUDGET = 1, 2
"""SOLVER_ITERATIONS (``predictive``): the solver's iteration limit; the solve's time budget."""
POSE_FEW_DOTS, POSE_REJECTED, SENSOR_FEW_DOTS, SENSOR_REJECTED = 1, 2, 4, 8
"""NO_POSE, the ``predictive`` law's PnP: fewer tracked dots than the target's points (or a
dot not finite); PnP gave no acceptable pose of the dots. The image sensor's PnP of
``depth = "pose"`` (:mod:`redservo.sensors.flags`): fewer than four detected dots of a point
set; no acceptable pose of its detected dots."""
