"""The ``predictive`` law's distances along its plan in one compiled call, broad phase first.

:func:`~redservo.redundancy.predictive_distance.horizon_distance_rows` needs, at each
predicted period ``k = 1…N`` of a step, the pairs closer than ``d_influence`` and their
Jacobians; :func:`~redservo.redundancy.predictive_distance.goal_clearance` and the campaigns'
reachability (:mod:`redservo.campaign.reach_obstacles`) only whether every pair is at least
``d_safe`` apart (:func:`~redservo.redundancy.predictive_distance.clear_of`: the same call
with the threshold ``d_safe``). Both used to measure every pair (:func:`~redservo.kernels.loop_collide.
measure_arm`, the capsule/cylinder and capsule/box searches included) through one Python
call per configuration. Here the broad phase of the compiled loop
(:func:`~redservo.kernels.loop_cull.measure_culled`) computes, with the very kernel
:func:`~redservo.kernels.loop_collide.pair_one` (so the same bits), every pair whose
distance may be below the threshold, and skips the others (``d = inf``, ``J = 0``): a pair
it skips has ``d > lb > threshold`` (loop_cull's argument), so the pairs below the
threshold, their order, their distances and Jacobians, and the smallest distance when it is
below the threshold, are those of the full measurement (tests/test_horizon_distance.py,
bit for bit on fuzzed states). Units: m, rad.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.loop_cull import measure_culled

__all__ = ["measure_plan"]


@kernel
def measure_plan(Q: Any, arm: Any, geom: Any, d_limit: float) -> Any:
    """``(d (N, P), J (N, P, n))`` at the configurations ``Q`` (N, n) (rad or m) of the DH
    chain ``arm`` among ``geom`` (:mod:`redservo.kernels.loop_collide`'s packs): every pair
    that may be closer than ``d_limit`` (m) as :func:`~redservo.kernels.loop_collide.
    measure_arm` gives it, ``inf`` and zeros for the pairs beyond (module docstring)."""
    N, n = Q.shape[0], Q.shape[1]
    P = geom[0].shape[0] * geom[2].shape[0] + geom[5].shape[0]
    D, JJ = np.empty((N, P)), np.empty((N, P, n))
    for k in range(N):
        d, J, _, _, _ = measure_culled(np.ascontiguousarray(Q[k]), arm, geom, d_limit)
        D[k], JJ[k] = d, J
    return D, JJ
