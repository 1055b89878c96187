"""A second process on a ROS 2 camera's topics, for tests/test_ros2_tracking.py: publishes
the frames of an ``.npz`` file (``frames``: (N, H, W, 3) uint8) as ``rgb8`` ``Image`` with
epoch stamps (``frame_id``: the frame's index) and, with ``--info``, the ``CameraInfo`` of
``camera`` ([px, py, u0, v0, width, height]); writes the stamps it published to OUT.json.

    python tests/ros2_image_peer.py DOMAIN FRAMES.npz OUT.json [--rate Hz] [--passes k]
        [--info] [--wait-reader] [--camera /camera]

``--wait-reader``: publish only once a reader of the image topic matched.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from redservo.camera import Camera
from redservo.ros2.images import info_message, rgb_message
from redservo.ros2.messages import CameraInfo, Header, Image, seconds_to_time
from redservo.ros2.transport import SENSOR_DATA, Ros2Node


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("domain", type=int)
    p.add_argument("frames")
    p.add_argument("out")
    p.add_argument("--rate", type=float, default=30.0)
    p.add_argument("--passes", type=int, default=1)
    p.add_argument("--info", action="store_true")
    p.add_argument("--wait-reader", action="store_true")
    p.add_argument("--camera", default="/camera", help="namespace of image_raw, camera_info")
    a = p.parse_args()
    data = np.load(a.frames)
    frames = data["frames"]
    node = Ros2Node(a.domain)
    writer = node.writer(f"{a.camera}/image_raw", Image, SENSOR_DATA)
    info = node.writer(f"{a.camera}/camera_info", CameraInfo, SENSOR_DATA) if a.info else None
    while a.wait_reader and writer.get_publication_matched_status().current_count == 0:
        time.sleep(0.01)
    time.sleep(0.2)  # discovery settles both ways
    stamps: list[list[int]] = []
    for _ in range(a.passes):
        for i, frame in enumerate(frames):
            header = Header(seconds_to_time(time.time()), str(i))
            if info is not None:
                px, py, u0, v0, w, h = (float(v) for v in data["camera"])
                info.write(info_message(Camera(px, py, u0, v0, int(w), int(h)), header))
            writer.write(rgb_message(frame, header))
            stamps.append([header.stamp.sec, header.stamp.nanosec])
            time.sleep(1.0 / a.rate)
    with open(a.out, "w") as f:
        json.dump({"stamps": stamps}, f)


if __name__ == "__main__":
    main()
