"""A :class:`~redservo.hardware.RobotInterface` over a ROS 2 arm's topics.

Reads ``sensor_msgs/msg/JointState`` (``joint_state_broadcaster``'s ``/joint_states``),
publishes ``std_msgs/msg/Float64MultiArray`` joint velocities to a ros2_control
``JointGroupVelocityController`` (``/<controller>/commands``); :meth:`Ros2Robot.stop`
publishes zeros. The joint names of each ``JointState`` are mapped to the model's joint
order (extra joints, e.g. gripper fingers, are ignored); a message that lacks one of the
joints or holds NaN for one is a :class:`~redservo.ros2.faults.MessageError` (the loop
stops the arm), never skipped. Stamps are converted from the epoch to the loop's clock
(:mod:`redservo.ros2.stamps`).

The last command is zero whatever ends the process short of SIGKILL: the servo loop calls
:meth:`Ros2Robot.stop` at the end of every run, :meth:`Ros2Robot.close` (and the ``with``
block, and an ``atexit`` hook) sends zero when the last command was not zero. Against
SIGKILL or a lost network only the arm's own command timeout protects (ros2_control's
controllers and the rehearsal arm stop when commands stop arriving).

Units: seconds, radians (m for prismatic joints), rad/s.
"""

from __future__ import annotations

import atexit
import math
import time
import warnings
import weakref
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_vector
from redservo.errors import ConfigurationError
from redservo.ros2.faults import MessageError
from redservo.ros2.messages import Float64MultiArray, JointState
from redservo.ros2.naming import validate_topic
from redservo.ros2.stamps import EpochStamps
from redservo.ros2.transport import COMMANDS, SENSOR_DATA, Ros2Node

__all__ = ["CLOSE_ACK_TIMEOUT", "Ros2Robot", "check_joint_names"]

CLOSE_ACK_TIMEOUT = 1.0
"""The longest :meth:`Ros2Robot.close` waits for the subscribers to acknowledge its zero (s)."""


def check_joint_names(joints: object, key: str = "joints") -> list[str]:
    """Return ``joints`` as a list of distinct non-empty strings, or raise naming ``key``."""
    if not isinstance(joints, list | tuple) or not joints:
        raise ConfigurationError(
            f"{key} must be a non-empty list of ROS joint names, got {joints!r}", argument=key
        )
    for name in joints:
        if not isinstance(name, str) or not name:
            raise ConfigurationError(
                f"{key} holds {name!r}: each joint name must be a non-empty string",
                argument=key,
            )
    dupes = sorted({n for n in joints if list(joints).count(n) > 1})
    if dupes:
        raise ConfigurationError(f"{key} names {dupes} more than once", argument=key)
    return list(joints)


class Ros2Robot:
    """A joint-velocity-controlled arm behind ROS 2 topics (module docstring).

    Args:
        node: The DDS participant (:class:`~redservo.ros2.transport.Ros2Node`); closed with
            the robot when ``own_node``.
        joints: The ROS joint names in the model's joint order; the velocity controller's
            ``joints`` parameter must list them in the same order.
        joint_states: The ``JointState`` topic (fully qualified).
        command: The velocity controller's command topic (fully qualified).
        stamps: Epoch-to-loop-clock conversion (default: estimated now).
        clock: The loop's clock (s), for the arrival times in :attr:`ages`.
        own_node: Close ``node`` in :meth:`close`.

    Raises:
        ConfigurationError: a joint name is empty or repeated, or a topic name is invalid.
    """

    def __init__(
        self,
        node: Ros2Node,
        joints: Sequence[str],
        *,
        joint_states: str = "/joint_states",
        command: str = "/forward_velocity_controller/commands",
        stamps: EpochStamps | None = None,
        clock: Callable[[], float] = time.monotonic,
        own_node: bool = False,
    ) -> None:
        self.joints = check_joint_names(list(joints))
        self.n = len(self.joints)
        self.joint_states = validate_topic(joint_states, "joint_states")
        self.command = validate_topic(command, "command")
        self.node, self.own_node = node, own_node
        self.stamps = stamps or EpochStamps(monotonic=clock)
        self.clock = clock
        self._reader = node.reader(self.joint_states, JointState, SENSOR_DATA)
        self._writer: Any = node.writer(self.command, Float64MultiArray, COMMANDS)
        self._last: tuple[float, FloatArray] | None = None
        self.ages: list[float] = []
        """Age (s) of each ``JointState`` at its arrival: loop clock minus converted stamp."""
        self.commands = 0
        self.stops = 0
        self._moving = False
        ref = weakref.ref(self)

        def _at_exit() -> None:
            robot = ref()
            if robot is not None:
                robot.close()

        self._atexit = _at_exit
        atexit.register(_at_exit)

    # -- joint states ---------------------------------------------------------------------------

    def _joint_positions(self, msg: JointState) -> FloatArray:
        index = {name: i for i, name in enumerate(msg.name)}
        missing = [j for j in self.joints if j not in index]
        if missing or len(msg.position) != len(msg.name):
            why = (
                f"lacks the joints {missing}"
                if missing
                else f"has {len(msg.name)} names but {len(msg.position)} positions"
            )
            raise MessageError(
                f"JointState on {self.joint_states} {why} (names in the message: "
                f"{list(msg.name)[:12]}; expected the joints {self.joints})",
                argument=self.joint_states,
            )
        q = np.array([msg.position[index[j]] for j in self.joints], dtype=np.float64)
        bad = [j for j, v in zip(self.joints, q) if not math.isfinite(v)]
        if bad:
            raise MessageError(
                f"JointState on {self.joint_states} holds a non-finite position for {bad}",
                argument=self.joint_states,
            )
        return q

    def poll(self) -> bool:
        """Take every ``JointState`` that arrived; return True when one did.

        Raises:
            MessageError: one of them lacks a joint or holds NaN.
        """
        got = False
        for msg in self._reader.take(N=256):
            if not isinstance(msg, JointState):
                continue  # an instance-state notification, not data
            q = self._joint_positions(msg)
            t = self.stamps.to_loop(msg.header.stamp)
            self.ages.append(self.clock() - t)
            self._last, got = (t, q), True
        return got

    def wait_for_joints(self, timeout: float) -> tuple[float, FloatArray]:
        """Wait up to ``timeout`` (s, wall time) for a ``JointState`` and return ``(t, q)``.

        Raises:
            MessageError: none arrived (naming the topic), or it was unusable.
        """
        deadline = time.monotonic() + timeout
        while not self.poll() and self._last is None:
            if time.monotonic() > deadline:
                raise MessageError(
                    f"no JointState on {self.joint_states} within {timeout:g} s (domain "
                    f"{self.node.domain_id}, network {self.node.network}): is the arm's "
                    "driver running, on the same domain and network?",
                    argument=self.joint_states,
                )
            time.sleep(0.005)
        assert self._last is not None
        return self._last

    def latest_joints(self) -> tuple[float, FloatArray] | None:
        """The newest reading taken so far ``(t, q)``, None before the first; takes no message
        (safe from another thread than the loop's: the tracker's)."""
        last = self._last
        return None if last is None else (last[0], last[1].copy())

    def read_joints(self) -> tuple[float, FloatArray]:
        """The newest joint reading ``(t, q)``: ``t`` on the loop's clock (s), ``q`` in the
        model's joint order. The same ``t`` again when nothing new arrived.

        Raises:
            MessageError: no ``JointState`` arrived yet, or the newest one is unusable.
        """
        self.poll()
        if self._last is None:
            raise MessageError(
                f"no JointState on {self.joint_states} yet (call wait_for_joints first)",
                argument=self.joint_states,
            )
        return self._last[0], self._last[1].copy()

    # -- commands -------------------------------------------------------------------------------

    def subscribers(self) -> int:
        """How many readers (the velocity controller, anything else) match the command topic."""
        if self._writer is None:
            return 0
        return int(self._writer.get_publication_matched_status().current_count)

    def wait_for_subscriber(self, timeout: float) -> int:
        """Wait up to ``timeout`` (s, wall time) for a reader of the command topic.

        A command nobody reads moves nothing and stops nothing: the servo refuses to start
        rather than run open-loop against a controller that is not loaded.

        Returns:
            The number of matched readers (>= 1).

        Raises:
            MessageError: nobody subscribed within ``timeout`` (naming the topic); nothing
                was sent.
        """
        deadline = time.monotonic() + timeout
        while (count := self.subscribers()) == 0:
            if time.monotonic() > deadline:
                raise MessageError(
                    f"nobody subscribes to {self.command} within {timeout:g} s (domain "
                    f"{self.node.domain_id}, network {self.node.network}): is the velocity "
                    "controller loaded and active (ros2 control list_controllers)? nothing "
                    "was sent",
                    argument=self.command,
                )
            time.sleep(0.005)
        return count

    def send_velocity(self, qdot: ArrayLike) -> None:
        """Publish the (n,) joint velocities ``qdot`` (rad/s or m/s) in the joints' order."""
        v = as_vector(qdot, "qdot", self.n)
        self._writer.write(Float64MultiArray(data=[float(x) for x in v]))
        self.commands += 1
        self._moving = bool(np.any(v != 0.0))

    def stop(self) -> None:
        """Publish zero velocity (safe to call at any time, twice)."""
        if self._writer is None:
            return
        self._writer.write(Float64MultiArray(data=[0.0] * self.n))
        self.stops += 1
        self._moving = False

    def close(self) -> None:
        """Send zero if the last command was not zero, wait until every matched reader has
        acknowledged it (at most :data:`CLOSE_ACK_TIMEOUT` s: a writer released at once may
        take the unsent zero with it, and the arm keeps its last velocity until its own
        watchdog; a zero not acknowledged in time is warned about), then release the topics
        (and the node when owned). Safe to call twice."""
        if self._writer is not None and self._moving:
            self.stop()
            if not self._writer.wait_for_acks(int(CLOSE_ACK_TIMEOUT * 1e9)):
                warnings.warn(
                    f"{self.command}: the zero velocity sent on close was not "
                    f"acknowledged by every subscriber within {CLOSE_ACK_TIMEOUT:g} s",
                    RuntimeWarning,
                    stacklevel=2,
                )
        self._writer = None
        atexit.unregister(self._atexit)
        if self.own_node:
            self.node.close()

    def __enter__(self) -> Ros2Robot:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
