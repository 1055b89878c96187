"""A control loop of your own around :class:`redservo.Controller`: each period, measure the
feature, ask the controller for the safe joint velocities, send them to the robot.

Here the "robot" is the Afma6 model integrated perfectly and the "camera" projects one 3-D
point; on hardware, replace ``measure`` and the integration by your tracker and your arm's
velocity interface (or use :class:`redservo.hardware.ServoLoop`, docs/real-robot.md).

    python examples/controller_loop.py [--method NAME] [--quick]
"""

from __future__ import annotations

import argparse

import numpy as np

import redservo
from redservo.control import JointLimitForce, Measurement
from redservo.features import PointFeature
from redservo.robots import Afma6
from redservo.spatial import inverse
from redservo.task import TaskTerm, VisualTask


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default="iterative-smooth", help="redservo.METHODS")
    parser.add_argument("--quick", action="store_true", help="20 periods only (tests)")
    args = parser.parse_args(argv)

    robot = Afma6()
    limits = robot.limits(rho=0.1, margin=0.01)
    task = VisualTask([TaskTerm(PointFeature(), "target")], [0.0, 0.0])  # centre the point
    ctrl = redservo.Controller(
        robot, task, redservo.make_law(args.method), limits,
        lam=0.5, dt=0.04,  # 1/s, s
        objectives=[JointLimitForce(kappa=0.5)],  # push away from the limits (MC05 eqs. 27-29)
    )  # fmt: skip

    q = np.array([0.0, 0.0, 0.3, 0.0, 0.3, 0.0])  # m, m, m, rad, rad, rad
    target = robot.fkine(q) @ np.array([0.12, -0.07, 0.6, 1.0])  # a point in the base frame

    def measure(q: np.ndarray) -> Measurement:
        """The camera: the point's normalized coordinates (x, y) and its inverse depth 1/Z."""
        P = inverse(robot.fkine(q)) @ target
        return Measurement(P[:2] / P[2], (np.array([1.0 / P[2]]),))

    ctrl.reset()
    qdot = np.zeros(robot.n)
    periods = 20 if args.quick else 300
    for k in range(periods):
        step = ctrl.step(q, measure(q), k * ctrl.dt, qdot_prev=qdot)
        qdot = step.qdot  # send to the arm (rad/s or m/s), always within its limits
        assert np.all(np.abs(qdot) <= limits.qdot_max)
        q = q + qdot * ctrl.dt  # the arm moves for one period
        if k % 10 == 0 or float(np.linalg.norm(step.state.e1)) < 1e-3:
            print(f"t = {k * ctrl.dt:5.2f} s  |e| = {np.linalg.norm(step.state.e1):.4f}")
        if float(np.linalg.norm(step.state.e1)) < 1e-3:
            break
    print(f"final point (x, y) = {measure(q).s}, q = {np.round(q, 3)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
