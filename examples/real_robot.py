"""Run a control law on a robot through the hardware servo loop (docs/real-robot.md).

Here the "robot" is :class:`~redservo.hardware.SimulatedRobot`: the Afma6 of the shipped
``cm01-gaze`` scenario with a realistic actuator (first-order lag, one period of transport
delay, velocity and acceleration saturation, a quantized and noisy encoder) and an ideal
camera. To drive a real arm, replace ``robot_iface`` and ``source`` below by your own
:class:`~redservo.hardware.RobotInterface` and :class:`~redservo.hardware.FeatureSource`
and drop the virtual clock; nothing else changes.

By default the run uses a virtual clock and takes about a second; ``--realtime`` runs it
on the wall clock (about 20 s for 245 periods of 80 ms), as it would on hardware.

    python examples/real_robot.py [--method iterative-smooth] [--realtime] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from redservo import make_law
from redservo.experiment.build import build
from redservo.hardware import (
    ActuatorModel,
    IdealFeatureSource,
    ServoLoop,
    SimulatedRobot,
    VirtualClock,
)
from redservo.records import outcome_text
from redservo.scenario import load_scenario


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default=None, help="control law (default: the scenario's)")
    parser.add_argument("--realtime", action="store_true", help="run on the wall clock")
    parser.add_argument("--out", default=None, help="write summary.json, log.npz, log.csv here")
    args = parser.parse_args(argv)

    # 1. The controller's side: model robot, task, law, limits, gain and period.
    exp = build(load_scenario("cm01-gaze"))
    law = make_law(args.method) if args.method else exp.law
    period, lam = exp.options.dt, exp.options.lam  # 0.08 s, 0.3 1/s

    # 2. The hardware side (here simulated). A real arm: your RobotInterface/FeatureSource.
    if args.realtime:
        clock, sleep = time.monotonic, time.sleep
    else:
        virtual = VirtualClock()
        clock, sleep = virtual, virtual.sleep
    actuator = ActuatorModel(
        tau=0.03,  # s, velocity-loop time constant of each drive
        delay_steps=1,  # one period between the command and its effect
        qdot_max=exp.limits.qdot_max,  # the drive saturates at the robot's documented rates
        qddot_max=exp.limits.qddot_max,
        encoder_resolution=[1e-6, 1e-6, 1e-6, 2e-5, 2e-5, 2e-5],  # m, m, m, rad, rad, rad
        encoder_noise_std=[2e-7, 2e-7, 2e-7, 5e-6, 5e-6, 5e-6],
        seed=0,
    )
    robot_iface = SimulatedRobot(exp.robot, actuator, exp.q0, clock, period=period)
    # The shield keeps q + T q̇ within the limits, but a drive with delay and lag goes on
    # moving after the command changes: keep out of the last few centimetres (degrees).
    limits = exp.limits.replace(margin_abs=actuator.stopping_distance(period))
    source = IdealFeatureSource(exp.task, exp.scene, robot_iface)

    # 3. The loop: fixed period, watchdog, command guard, clean stop.
    loop = ServoLoop(
        robot_iface,
        source,
        exp.robot,
        exp.task,
        law,
        limits,
        period=period,
        lam=lam,
        watchdog_timeout=3 * period,
        max_iterations=exp.options.max_iterations,
        tolerance=exp.options.tolerance,
        clock=clock,
        sleep=sleep,
    )
    t0 = time.perf_counter()
    result = loop.run(raise_errors=False)
    wall = time.perf_counter() - t0

    s = result.summary
    print(f"outcome: {outcome_text(s)} ({result.reason})")
    print(f"iterations: {result.iterations}, servo time {result.iterations * period:.2f} s, "
          f"wall time {wall:.2f} s")  # fmt: skip
    print(f"final |e1|: {s['final_error_norm']:.2e}, min margin to a limit: {s['min_margin']:.3f}")
    print(f"overruns: {result.overruns}, max cycle time: {1e3 * s['max_cycle_time']:.2f} ms, "
          f"held: {s['held']}, guarded: {s['guarded']}")  # fmt: skip
    err = np.abs(robot_iface.q - result.log.q[-1])
    print(f"true q vs last encoder reading: max {err.max():.2e} (m or rad)")
    if args.out:
        print(f"log written to {result.save(args.out)}")
    return 0 if result.outcome == "converged" else 1


if __name__ == "__main__":
    sys.exit(main())
