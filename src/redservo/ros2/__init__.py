"""ROS 2 over DDS without a ROS install (``pip install 'redservo[ros2]'``: ``cyclonedds``).

A :class:`~redservo.hardware.RobotInterface` over a ROS 2 arm's topics (``JointState`` in,
``Float64MultiArray`` velocity commands out), the ROS 2 messages as Cyclone DDS types, the
conversion of ROS 2 stamps (epoch) to the loop's monotonic clock, and the rehearsal arm
(``redservo sim-arm``) that serves a MuJoCo arm on the same topics. docs/real-robot.md,
"Connecting a ROS 2 arm".

The submodules import ``cyclonedds``; this package itself does not, so ``import
redservo.ros2`` works without the extra.
"""
