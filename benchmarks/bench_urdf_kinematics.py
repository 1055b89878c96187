"""Benchmark: URDF robots' kinematics, the compiled chain against Pinocchio (issue 18, item 3).

    .venv/bin/python benchmarks/bench_urdf_kinematics.py [--rounds R] [--calls N]

Times, in µs per call (medians over R interleaved rounds of N calls, each call at a new
random q within the limits so that no cache helps):

* ``URDFRobot.kinematics`` (validation of q + the chain kernel, :mod:`redservo.kernels.chain`);
* ``URDFRobot.pinocchio_kinematics`` (validation of q + Pinocchio: the operations of
  ``kinematics`` before the chain kernel, now the oracle);
* ``Panda().kinematics`` (the DH model, for comparison);
* the 4-point step of ``panda-urdf-4points`` (iterative-smooth): the public path
  (``robot.kinematics`` + ``task.evaluate`` + ``law(...)``) and the campaign loop's compiled iteration
  (:func:`redservo.bench.sensed.sensed_iteration`).

Run on an older tree (``PYTHONPATH=<old>/src``) it times what that tree has: there,
``kinematics`` is Pinocchio and a URDF robot has no compiled step. The machine is shared:
the first line prints the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

Timed = dict[str, tuple[Callable[[np.ndarray], Any], list[Any]]]


def _median_us(fns: Timed, rounds: int) -> dict[str, float]:
    """Interleaved rounds: each round calls every function once per q; median µs per call."""
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(rounds):
        for name, (fn, qs) in fns.items():
            t0 = time.perf_counter()
            for q in qs:
                fn(q)
            times[name].append((time.perf_counter() - t0) / len(qs) * 1e6)
    return {name: statistics.median(v) for name, v in times.items()}


def _step_functions(exp: Any) -> dict[str, Callable[[np.ndarray], Any]]:
    from redservo.errors import ConfigurationError
    from redservo.redundancy import make_law

    robot, scene, task, limits = exp.robot, exp.scene, exp.task, exp.limits
    lam, dt = float(exp.options.lam), exp.options.dt
    law = make_law("iterative-smooth")

    def public(q: np.ndarray) -> Any:
        bMc, J = robot.kinematics(q)
        state = task.evaluate(scene, bMc, J, 0.0)
        return law(J1=state.J1, e1=state.e1, q=q, limits=limits, lam=lam, dt=dt).qdot

    out: dict[str, Callable[[np.ndarray], Any]] = {"step, public path": public}
    try:
        from redservo.bench.sensed import sensed_iteration

        run = sensed_iteration(robot, scene, task, law, limits=limits, lam=lam, dt=dt)
        out["step, campaign iteration"] = run
    except (ImportError, ConfigurationError) as exc:
        print(f"campaign iteration: not available for this robot here ({exc})")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=30)
    parser.add_argument("--calls", type=int, default=200)
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")
    from redservo.experiment.build import build
    from redservo.robots import Panda
    from redservo.scenario import load_scenario

    exp = build(load_scenario("panda-urdf-4points"))
    robot, dh = exp.robot, Panda()
    rng = np.random.default_rng(0)
    margin = 0.2 * (robot.q_max - robot.q_min)
    qs = [rng.uniform(robot.q_min + margin, robot.q_max - margin) for _ in range(args.calls)]
    near = [exp.q0 + rng.normal(0.0, 0.02, robot.n) for _ in range(args.calls)]  # target seen
    fns: Timed = {"URDFRobot.kinematics": (robot.kinematics, qs)}
    if hasattr(robot, "pinocchio_kinematics"):
        fns["URDFRobot.pinocchio_kinematics"] = (robot.pinocchio_kinematics, qs)
    fns["Panda (DH).kinematics"] = (dh.kinematics, qs)
    fns.update({name: (fn, near) for name, fn in _step_functions(exp).items()})
    for fn, q_list in fns.values():  # warm up: compile or load the kernels
        fn(q_list[0])
    med = _median_us(fns, args.rounds)
    print(f"{args.rounds} rounds x {args.calls} calls, median µs per call:")
    for name, us in med.items():
        print(f"  {name:34s} {us:8.2f}")


if __name__ == "__main__":
    main()
