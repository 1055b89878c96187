"""The set-ups ``redservo bench`` times: what users run, self-contained.

* ``afma6-4points``: 4-point IBVS on the Afma6, a 0.2 m square seen at 0.6 m, the start
  rotated 80° about the optical axis: the classical law makes the camera retreat and the
  ``z`` gantry joint (joint 3) enters its band (it reaches -0.42 m, threshold -0.40 m,
  limit -0.50 m). m = 6 (CM01 eq. 25 combination of the 8 point coordinates), n = 6.
* ``afma6-gaze``: CM01's gazing task (one point, m = 2, n = 6) near the limits.
* ``afma6-moments``: the six moment features of 4 non-symmetric coplanar points (m = 6).
* ``panda-6d-free`` / ``panda-6d-bounds``: the Panda (n = 7) on a 4-point task (m = 6),
  from the ready posture (no bound active) and with the elbow on its safe limit (the
  state of the ``panda-4points`` scenario where ``sns`` saturates the elbow and scales the
  task, and ``qp`` calls its solver).
* ``dh-n``: a 4-point task (m = 6) on a seeded DH chain of n revolute joints, for the
  scaling with n (6 to 50).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.features import MomentFeatures, PointFeature
from redservo.limits import JointLimits
from redservo.robots import Afma6, DHLink, DHRobot, Panda, Robot
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

__all__ = ["SCALING_N", "BenchCase", "bench_cases", "dh_chain", "scaling_case"]

SCALING_N: tuple[int, ...] = (6, 10, 20, 30, 50)
"""Joint counts of the scaling cases."""
SQUARE = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])
"""A 0.2 m square (m), object frame."""
_BLOB = np.array([[-0.05, -0.04, 0.0], [0.07, -0.05, 0.0], [0.04, 0.06, 0.0], [-0.06, 0.03, 0.0]])
_PANDA_Q0 = (0.0, -0.785, 0.0, -2.8, 0.0, 1.571, 0.785)
_PANDA_ACTIVE = (0.09698, -0.11834, 0.00403, -3.04178, 0.04065, 2.15143, 0.4808)


@dataclass(frozen=True)
class BenchCase:
    """A robot, a static scene, a task and a configuration to time one control step at."""

    name: str
    robot: Robot
    scene: Scene
    task: VisualTask
    q: FloatArray
    limits: JointLimits
    lam: float = 0.5
    dt: float = 0.04

    @property
    def label(self) -> str:
        """``name (m=.., n=..)``."""
        return f"{self.name} (m={self.task.m}, n={self.robot.n})"


def _points_case(
    name: str, robot: Robot, q: Any, bMo: FloatArray, desired: FloatArray, **kw: Any
) -> BenchCase:
    scene = Scene([PointSet("t", SQUARE, trajectory=Static(bMo))])
    task = VisualTask.from_desired_poses(
        [TaskTerm(PointFeature(p), "t") for p in SQUARE], {"t": desired}
    )
    lim = kw.pop("limits", robot.limits())
    return BenchCase(name, robot, scene, task, np.asarray(q, dtype=float), lim, **kw)


def _afma6_cases() -> list[BenchCase]:
    afma = Afma6()
    q4 = np.array([0.0, 0.0, -0.25, 0.0, 0.25, 0.0])
    cdMo = make_transform(t=(0.0, 0.0, 0.6))
    rot80 = make_transform(rotvec=(0.0, 0.0, np.deg2rad(80.0)))
    four = _points_case("afma6-4points", afma, q4, afma.fkine(q4) @ rot80 @ cdMo, cdMo)
    q_g = np.array([-0.5967, -0.165, 0.4119, 1.2829, 0.3967, -0.6108])
    gaze_target = afma.fkine(q_g) @ make_transform(t=(-0.368, 0.017, 0.876))
    gaze = BenchCase(
        "afma6-gaze",
        afma,
        Scene([PointSet("t", np.zeros((1, 3)), trajectory=Static(gaze_target))]),
        VisualTask([TaskTerm(PointFeature(), "t")], [0.0, 0.0]),
        q_g,
        afma.limits(),
    )
    q_m = afma.limits().center + np.array([0.2, -0.1, 0.1, 0.3, 0.2, -0.2])
    bMo = afma.fkine(q_m) @ make_transform(t=(0.05, -0.03, 0.7), rotvec=(0.1, -0.1, 0.2))
    desired = make_transform(t=(0.0, 0.0, 0.5))
    moments = BenchCase(
        "afma6-moments",
        afma,
        Scene([PointSet("t", _BLOB, trajectory=Static(bMo))]),
        VisualTask.from_desired_poses(
            [TaskTerm(MomentFeatures.at_desired_pose(_BLOB, desired), "t")], {"t": desired}
        ),
        q_m,
        afma.limits(),
    )
    return [four, gaze, moments]


def _panda_cases() -> list[BenchCase]:
    panda = Panda()
    lim = panda.limits(margin=0.01)
    desired = make_transform(t=(0.0, 0.0, 0.338))
    ready = Panda.ready_configuration()
    free_target = panda.fkine(ready) @ make_transform(
        t=(0.01, -0.01, 0.36), rotvec=(0.02, -0.02, 0.03)
    )
    q0 = np.array(_PANDA_Q0)
    start = make_transform(t=(-0.071, 0.043, 0.583), rotvec=(-0.22, -0.272, -0.39))
    return [
        _points_case("panda-6d-free", panda, ready, free_target, desired, limits=lim),
        _points_case(
            "panda-6d-bounds", panda, _PANDA_ACTIVE, panda.fkine(q0) @ start, desired, limits=lim
        ),
    ]


def dh_chain(n: int, seed: int = 0) -> DHRobot:
    """A seeded chain of ``n`` revolute joints, about 0.9 m long, twists ±π/2 or 0."""
    rng = np.random.default_rng(seed)
    length = 0.9 / n
    links = [
        DHLink(
            a=float(length * rng.uniform(0.5, 1.5)),
            d=float(length * rng.uniform(0.0, 0.5)),
            alpha=float(rng.choice([-np.pi / 2, 0.0, np.pi / 2])),
            q_min=-2.5,
            q_max=2.5,
        )
        for _ in range(n)
    ]
    return DHRobot(links, name=f"dh{n}", qdot_max=2.0, qddot_max=10.0)


def scaling_case(n: int) -> BenchCase:
    """The 4-point task on :func:`dh_chain` ``(n)`` at a seeded mid-range configuration."""
    robot = dh_chain(n)
    q = np.random.default_rng(n).uniform(-0.5, 0.5, n)
    desired = make_transform(t=(0.0, 0.0, 0.5))
    start = make_transform(t=(0.02, -0.01, 0.55), rotvec=(0.05, -0.04, 0.3))
    return _points_case(f"dh-{n}", robot, q, robot.fkine(q) @ start, desired)


def bench_cases(scaling: tuple[int, ...] = SCALING_N) -> list[BenchCase]:
    """Every case of the module docstring (scaling cases for the joint counts given)."""
    return [*_afma6_cases(), *_panda_cases(), *(scaling_case(n) for n in scaling)]
