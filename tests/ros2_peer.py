"""A second process on the ROS 2 topics, for tests/test_ros2_robot.py: publishes
``JointState`` (with faults on request) and records the velocity commands it receives.

    python tests/ros2_peer.py DOMAIN OUT.json [--duration s] [--rate Hz] [--stamps epoch|
        monotonic|future] [--names a,b,...] [--nan-after k] [--no-commands]

``--no-commands``: no reader of the command topic (a velocity controller that is not loaded).
"""

from __future__ import annotations

import argparse
import json
import time

from redservo.ros2.messages import Float64MultiArray, Header, JointState, seconds_to_time
from redservo.ros2.transport import Ros2Node

NAMES = [f"joint{i}" for i in range(1, 7)]


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("domain", type=int)
    p.add_argument("out")
    p.add_argument("--duration", type=float, default=2.0)
    p.add_argument("--rate", type=float, default=100.0)
    p.add_argument("--stamps", default="epoch")
    p.add_argument("--names", default=",".join(["finger", *reversed(NAMES)]))
    p.add_argument("--nan-after", type=int, default=-1)
    p.add_argument("--no-commands", action="store_true")
    p.add_argument("--prefix", default="", help="topics under this namespace (e.g. /t123)")
    a = p.parse_args()
    node = Ros2Node(a.domain)
    writer = node.writer(f"{a.prefix}/joint_states", JointState)
    reader = None
    if not a.no_commands:
        reader = node.reader(f"{a.prefix}/forward_velocity_controller/commands", Float64MultiArray)
    names = a.names.split(",")
    received: list[list[float]] = []
    end, k = time.monotonic() + a.duration, 0
    while time.monotonic() < end:
        now = {"epoch": time.time(), "monotonic": time.monotonic(), "future": time.time() + 10}
        # position of "jointN" is 0.1*N, of anything else -1
        pos = [0.1 * int(n[5:]) if n.startswith("joint") else -1.0 for n in names]
        if 0 <= a.nan_after <= k:
            pos[-1] = float("nan")
        stamp = seconds_to_time(now[a.stamps])
        writer.write(JointState(Header(stamp, "base"), names, pos, [], []))
        if reader is not None:
            msgs = reader.take(N=100)
            received += [list(m.data) for m in msgs if isinstance(m, Float64MultiArray)]
        k += 1
        time.sleep(1.0 / a.rate)
    with open(a.out, "w") as f:
        json.dump({"received": received, "published": k}, f)


if __name__ == "__main__":
    main()
