"""The hardware commands over ROS 2 (:mod:`redservo.ros2`; need ``redservo[ros2]``).

    redservo servo SCENARIO --hardware FILE.toml [--out DIR] [--yes] [--dry-run]
                   [--speed-scale s] [--set key=value ...]
    redservo sim-arm SCENARIO [--domain-id N] [--network loopback|system] [--joints a,b,...]
                     [--joint-states TOPIC] [--command TOPIC] [--rate HZ]
                     [--command-timeout S] [--duration S] [--camera] [--out FILE]

Registered by :func:`register` into the parser (:mod:`redservo.cli.parser`).
Exit codes as every command (2: bad input, one line); ``servo`` returns 1 when the run
ended on a fault (``stale_measurement``, ``clock_fault``, ``error``, ``interrupted``) and
when the user did not confirm.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
from pathlib import Path
from typing import Any

from redservo.records.verdict import outcome_text

__all__ = ["register"]

_OK = ("converged", "max_iterations", "duration", "stopped")


def register(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add ``servo`` and ``sim-arm`` to the ``redservo`` subparsers."""
    s = sub.add_parser(
        "servo",
        parents=[common],
        help="run a scenario's controller on an arm (ROS 2 topics; docs/real-robot.md)",
        description="Check the arm (topics, joint names, limits, start pose), ask, run the "
        "scenario's controller through ServoLoop and write the run directory with timing.json "
        "(docs/real-robot.md, Connecting a ROS 2 arm).",
    )
    s.add_argument("scenario", help="a shipped scenario name or a .toml file")
    s.add_argument("--hardware", required=True, metavar="FILE.toml", help="the hardware file")
    s.add_argument("--out", help="run directory (default runs/NAME-servo)")
    s.add_argument("--yes", action="store_true", help="do not ask before the first command")
    s.add_argument("--dry-run", action="store_true", help="compute and record, send nothing")
    s.add_argument("--speed-scale", type=float, default=1.0, help="factor (0, 1] on qdot_max")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a key")
    s.set_defaults(func=_cmd_servo, compiles=True)

    a = sub.add_parser(
        "sim-arm",
        parents=[common],
        help="serve a scenario's MuJoCo arm on ROS 2 topics (a rehearsal arm)",
        description="Publish JointState (epoch stamps), execute Float64MultiArray velocity "
        "commands through the arm's dynamics in real time, stop by itself when commands stop.",
    )
    a.add_argument("scenario", help="a shipped scenario name or a .toml file")
    a.add_argument("--domain-id", type=int, default=0, help="ROS_DOMAIN_ID (default 0)")
    a.add_argument("--network", choices=("loopback", "system"), default="loopback")
    a.add_argument("--joints", help="ROS joint names, comma-separated (default: the model's)")
    a.add_argument("--joint-states", default="/joint_states")
    a.add_argument("--command", default="/forward_velocity_controller/commands")
    a.add_argument("--rate", type=float, default=250.0, help="joint-state rate (Hz)")
    a.add_argument("--command-timeout", type=float, default=0.1, help="stop after (s)")
    a.add_argument("--duration", type=float, help="serve this long (s; default: until stopped)")
    a.add_argument("--camera", action="store_true", help="publish the rendered camera view")
    a.add_argument("--image", default="/camera/image_raw", help="Image topic")
    a.add_argument("--camera-info", default="/camera/camera_info", help="CameraInfo topic")
    a.add_argument("--image-rate", type=float, default=10.0, help="camera frame rate (Hz)")
    a.add_argument("--out", metavar="FILE", help="write what the arm saw (JSON) at the end")
    a.set_defaults(func=_cmd_sim_arm)


def _experiment(scenario: str, sets: list[str] | None) -> Any:
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    sc = load_scenario(scenario)
    if sets:
        sc = apply_overrides(sc, sets)
    return build(sc)


def _ask(what: str) -> bool:
    print(f"redservo servo: {what}.", file=sys.stderr)
    print("Keep a hand on the arm's stop. Start? [y/N] ", end="", file=sys.stderr, flush=True)
    try:
        return input().strip().lower() in ("y", "yes")
    except EOFError:
        return False


def _cmd_servo(args: argparse.Namespace) -> int:
    from redservo.ros2.hardware_file import load_hardware
    from redservo.ros2.servo_run import save_run, servo_on_hardware

    spec = load_hardware(args.hardware)
    exp = _experiment(args.scenario, args.set)
    result, timing = servo_on_hardware(
        exp,
        spec,
        dry_run=args.dry_run,
        speed_scale=args.speed_scale,
        confirm=None if args.yes else _ask,
    )
    if result is None:
        print("redservo: not confirmed; no command was sent", file=sys.stderr)
        return 1
    out = save_run(
        result, exp, Path(args.out or Path("runs") / f"{exp.scenario.name}-servo"), timing
    )
    summary = dict(result.summary, outcome=result.outcome)
    jit = timing.get("jitter_p99")
    print(
        f"{exp.scenario.name} [servo{' dry run' if args.dry_run else ''}]: "
        f"{outcome_text(summary)} after {result.summary.get('iterations')} iterations; jitter p99 "
        f"{'-' if jit is None else f'{jit * 1e3:.2f} ms'}; {result.summary.get('reason', '')}"
    )
    print(f"run directory: {out}", file=sys.stderr)
    return 0 if result.outcome in _OK else 1


def _cmd_sim_arm(args: argparse.Namespace) -> int:
    from redservo.ros2.robot import check_joint_names
    from redservo.ros2.sim_arm import RehearsalArm
    from redservo.ros2.transport import Ros2Node

    joints = None if args.joints is None else check_joint_names(args.joints.split(","), "--joints")
    exp = _experiment(args.scenario, None)
    node = Ros2Node(args.domain_id, network=args.network)
    arm = RehearsalArm(
        exp,
        node,
        joints=joints,
        joint_states=args.joint_states,
        command=args.command,
        rate=args.rate,
        command_timeout=args.command_timeout,
    )
    if args.camera:
        from redservo.ros2.sim_camera import SimCamera

        arm.camera = SimCamera(
            exp,
            node,
            arm.stamps,
            image=args.image,
            camera_info=args.camera_info,
            rate=args.image_rate,
        )
    signal.signal(signal.SIGTERM, lambda *_: arm.stop_event.set())
    print(
        f"sim-arm: {exp.scenario.name} on domain {args.domain_id} ({args.network}): "
        f"{args.joint_states}, {args.command}; Ctrl-C to stop",
        file=sys.stderr,
        flush=True,
    )
    try:
        stats = arm.run(args.duration)
    except KeyboardInterrupt:
        stats = arm.stats
    if args.out:
        Path(args.out).write_text(json.dumps(stats.to_dict(), indent=2) + "\n")
    return 0
