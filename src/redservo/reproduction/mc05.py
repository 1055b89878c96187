"""MC05 §V: what the two experiments share (the avoidance split, the occluder's image, criteria).

MC05 runs two experiments on a 6-DOF eye-in-hand robot observing four dots through the six
moment features of docs/formulas.md §3.4:

* **joint limits** (full-rank task, Figs. 2-4): :mod:`~redservo.reproduction.mc05_joint_limits`,
  and a variant where the limited axis moves the camera along its optical axis,
  :mod:`~redservo.reproduction.mc05_optical_axis`;
* **occlusion** (4-DOF task, Figs. 5-7): :mod:`~redservo.reproduction.mc05_occlusion`.

**Avoidance velocities** (Fig. 5) are computed from the logs, not logged by the simulator: at
each logged iteration the controller's ``J1`` and ``e1`` are rebuilt from the logged
(measured) features, the logged ``q`` and ``t`` and the run's depth error, and
``q̇2 = q̇ - q̇1`` with ``q̇1 = -λ J1^+ e1`` the primary part of every law used here; Fig. 5
plots the camera-frame translational part of ``J(q) q̇2``.

Shared criteria (decisions; MC05 gives no numbers):

* *not slowed* (MC05 eq. 9): ``‖e1‖`` decreases at every step at least by the classical
  factor, ``‖e1(k+1)‖ <= (1 - λ dt)(1 + DECAY_SLACK) ‖e1(k)‖`` while ``‖e1‖ > 10 tol``
  (eq. 9 bounds the *predicted* error; ``DECAY_SLACK`` absorbs the second-order effect of a
  finite step) — :func:`worst_step`;
* *accelerated* feature: ``Σ_t |e_i(t)| / Σ_t |e_i^ref(t)|`` below ``ACCELERATION_RATIO``
  against a reference run over the common time span — :func:`feature_acceleration`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.experiment.build import Experiment
from redservo.redundancy.linalg import DEFAULT_RCOND, pinv
from redservo.scene import PointSet, Sphere
from redservo.simulation import SimulationResult

__all__ = [
    "ACCELERATION_RATIO",
    "DECAY_SLACK",
    "FEATURES",
    "AvoidanceSplit",
    "avoidance_split",
    "clearance",
    "feature_acceleration",
    "in_band",
    "occluder_disc",
    "pyplot",
    "target_image",
    "worst_step",
]

DECAY_SLACK = 1e-3
"""Relative slack on 'the error norm decreases at least as fast as (1 - λ dt) per step'."""
ACCELERATION_RATIO = 0.95
"""Largest ``Σ|e_i^dir| / Σ|e_i^ref|`` for 'the decrease of feature i is accelerated'."""
FEATURES = ("xn", "yn", "an", "α", "r1", "r2")
"""Names of the six moment features (docs/formulas.md §3.4)."""


class AvoidanceSplit:
    """The primary and secondary parts of a logged command (arrays over the N logged iterations).

    Attributes:
        qdot1: (N, n) primary joint velocity ``-λ J1^+ e1``.
        qdot2: (N, n) secondary (avoidance) joint velocity ``q̇ - q̇1``.
        twist2: (N, 6) camera twist of the secondary part, ``J(q) q̇2`` (camera frame).
        task2: (N, m) effect of the secondary part on the task, ``J1 q̇2``.
    """

    def __init__(self, qdot1: FloatArray, qdot2: FloatArray, twist2: FloatArray, task2: FloatArray):
        self.qdot1 = qdot1
        self.qdot2 = qdot2
        self.twist2 = twist2
        self.task2 = task2


def avoidance_split(result: SimulationResult, exp: Experiment) -> AvoidanceSplit:
    """Split each logged command into ``q̇1 = -λ J1^+ e1`` and the rest (see the module docstring).

    ``J1`` and ``e1`` are the controller's: the task is re-evaluated from the *logged*
    (measured) features at the logged ``q`` and ``t``, with the true inverse depth scaled by
    the run's depth error. Valid for runs without calibration error and without feed-forward.
    """
    log = result.log
    lam = exp.options.constant_lam
    n = exp.robot.n
    N = len(log)
    qdot1 = np.zeros((N, n))
    twist2 = np.zeros((N, 6))
    task2 = np.zeros((N, exp.task.m))
    for i in range(N):
        q = log.q[i]
        bMc = exp.robot.fkine(q, check_limits=False)
        J = exp.robot.jacobian(q, check_limits=False)
        _, inv_depth = exp.task.measure(exp.scene, bMc, float(log.t[i]))
        st = exp.task.evaluate_measured(
            np.array(log.s[i]), inv_depth, J, depth_scale=exp.options.depth_scale
        )
        qdot1[i] = -lam * (pinv(st.J1, DEFAULT_RCOND) @ st.e1)
        q2 = log.qdot[i] - qdot1[i]
        twist2[i] = J @ q2
        task2[i] = st.J1 @ q2
    return AvoidanceSplit(qdot1, log.qdot - qdot1, twist2, task2)


def occluder_disc(exp: Experiment, q: FloatArray, t: float) -> tuple[FloatArray, float] | None:
    """The sphere's image disc (centre (2,), radius, normalized units) at ``q``, ``t``, or None.

    Same approximation as the simulator: centre ``X0/Z0``, radius ``r/sqrt(Z0² - r²)``; None
    when the sphere is not in front of the camera (``Z0 <= r``).
    """
    occ = exp.options.occlusion
    if occ is None:
        return None
    sph = exp.scene.object(occ.occluder)
    assert isinstance(sph, Sphere)
    cMo = exp.scene.cMo(occ.occluder, exp.robot.fkine(q, check_limits=False), t)
    X0 = cMo[:3, :3] @ np.asarray(sph.center, dtype=float) + cMo[:3, 3]
    r = float(sph.radius)
    if X0[2] <= r:
        return None
    return np.asarray(X0[:2] / X0[2]), float(r / np.sqrt(X0[2] ** 2 - r**2))


def target_image(exp: Experiment, q: FloatArray, t: float, name: str = "target") -> FloatArray:
    obj = exp.scene.object(name)
    assert isinstance(obj, PointSet)
    cMo = exp.scene.cMo(name, exp.robot.fkine(q, check_limits=False), t)
    P = np.asarray(obj.points) @ cMo[:3, :3].T + cMo[:3, 3]
    return np.asarray(P[:, :2] / P[:, 2:3])


def clearance(exp: Experiment, result: SimulationResult) -> FloatArray:
    """(N,) smallest distance (normalized units) from a dot to the sphere's disc; +inf if none."""
    log = result.log
    out = np.full(len(log), np.inf)
    for i in range(len(log)):
        disc = occluder_disc(exp, log.q[i], float(log.t[i]))
        if disc is None:
            continue
        xy = target_image(exp, log.q[i], float(log.t[i]))
        out[i] = float(np.min(np.linalg.norm(xy - disc[0], axis=1)) - disc[1])
    return out


def worst_step(result: SimulationResult, exp: Experiment) -> float:
    """Largest ``‖e1(k+1)‖ / ‖e1(k)‖`` over the steps that start with ``‖e1‖ > 10 tol``."""
    e = result.log.error_norm
    step = e[1:] / np.maximum(e[:-1], 1e-300)
    moving = e[:-1] > 10 * exp.options.tolerance
    return float(step[moving].max()) if moving.any() else 0.0


def in_band(exp: Experiment, result: SimulationResult) -> NDArray[np.bool_]:
    """(N,) some axis is in its critical band (or beyond) at each logged iteration."""
    return np.asarray(np.any(exp.limits.in_band(result.log.q), axis=1), dtype=bool)


def pyplot() -> Any:
    """The lazily imported ``matplotlib.pyplot``."""
    from redservo.plots.style import _plt

    return _plt()


def feature_acceleration(result: SimulationResult, reference: SimulationResult) -> FloatArray:
    """(k,) ``Σ_t |e_i(t)| / Σ_t |e_i^ref(t)|`` over the common time span (< 1: decreased faster)."""
    n = min(len(result.log), len(reference.log))
    num = np.sum(np.abs(result.log.e[:n]), axis=0)
    den = np.maximum(np.sum(np.abs(reference.log.e[:n]), axis=0), 1e-300)
    return np.asarray(num / den)
