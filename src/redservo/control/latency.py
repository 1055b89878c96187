"""Latency compensation: a delayed measurement brought to the present (Smith predictor).

A camera's measurement describes the instant its image was exposed, its **stamp**
``t_s`` (:attr:`redservo.sensors.SensorReading.stamp`), and reaches the controller at
``t > t_s``. Since ``t_s`` the robot has moved by the commands the controller sent, which
the camera has not seen. With the interaction model ``L`` (k, 6) at the measured features
(the task's depth option, the controller's depth estimate) and the model Jacobian
``J(q_k)`` (6, n) of each command ``q̇_k`` in force over ``[t_k, t_k + T)``:

    ``ŝ(t) = s(t_s) + L(s(t_s), 1/Ẑ) · Σ_k J(q_k) q̇_k · |[t_k, t_k + T) ∩ [t_s, t)|``

the features predicted at ``t`` (normalized image units), to first order in the motion.
:class:`CommandHistory` keeps the commands with their times, so the controller knows which
of them the camera has already seen (those before ``t_s``). The prediction is exact for a
static target and a small motion; it knows nothing of the target's own motion during the
latency (the feed-forward's job).

Units: seconds; ``q̇`` in rad/s or m/s; the camera twist ``J q̇`` in m/s and rad/s.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray, as_time
from redservo.control.steps import Features, Measurement
from redservo.errors import ShapeError
from redservo.kernels import lazy
from redservo.task import VisualTask

if TYPE_CHECKING:  # the kernel module, typed; imported on first use at run time
    from redservo.binding.control import CompiledControl
    from redservo.kernels import latency as _K
else:
    _K = lazy("latency")

__all__ = ["CommandHistory", "present"]

_EPS = 1e-9  # s


class _Command(tuple):
    """One command of the history: ``(t, q, source, part)`` or ``(t, q, source, part,
    twist)``, read by name (``t`` in s, ``q`` and ``qdot`` (n,), ``twist`` (6,) or None).
    ``qdot`` is ``source`` itself (``part`` None) or its ``part`` (the compiled step's
    buffer, which no one writes into); ``source`` may be a row of the history's ring (the
    entry's own while it is in the history: a slot is written again only after its entry
    left, and a grown ring writes into new arrays); the twist ``J(q) q̇`` is added by
    :meth:`CommandHistory.motion` once it needs it. A tuple made by ``tuple.__new__``
    (:meth:`CommandHistory.keep`, once per control step)."""

    __slots__ = ()

    @property
    def t(self) -> float:
        return self[0]

    @property
    def q(self) -> FloatArray:
        return self[1]

    @property
    def qdot(self) -> FloatArray:
        source, part = self[2], self[3]
        return source if part is None else source[part]

    @property
    def twist(self) -> FloatArray | None:
        return self[4] if len(self) > 4 else None


_new_command: Callable[[type[_Command], tuple[object, ...]], _Command] = tuple.__new__


class CommandHistory:
    """The commands sent, with their times (module docstring).

    The commands are kept in order of arrival, and their times and camera twists in a
    ring of arrays as well, which :func:`redservo.kernels.latency.motion` sums in one
    compiled call.

    Args:
        period: How long (s) a command stays in force when no later one follows: the
            control period ``T``.
        jacobian: ``J(q)`` (6, n), the model Jacobian, computed only for the commands a
            measurement has not seen.
        horizon: Commands older than this (s) before the newest are forgotten.
    """

    def __init__(
        self, period: float, jacobian: Callable[[FloatArray], FloatArray], horizon: float = 1.0
    ) -> None:
        self.period, self.jacobian, self.horizon = float(period), jacobian, float(horizon)
        self._cmds: deque[_Command] = deque()
        self._ordered = True  # every command later than the one before
        self._ring = _Ring(64)

    def reset(self) -> None:
        """Forget every command (start of a run)."""
        self._cmds.clear()
        self._ordered = True
        self._ring.head = 0

    def record(self, t: float, q: FloatArray, qdot: FloatArray) -> None:
        """The command ``qdot`` (n,) sent at ``t`` (s) with the robot at ``q`` (n,)."""
        self.keep(float(t), q.copy(), qdot.copy())

    def keep(
        self,
        t: float,
        q: FloatArray,
        qdot: FloatArray,
        part: slice | None = None,
        in_ring: bool = False,
    ) -> None:
        """:meth:`record` with copies the caller already made, kept as given: ``q`` (n,),
        and the command ``qdot`` (n,) or, with ``part``, ``qdot[part]`` (the compiled step's
        buffer). No one may write into them afterwards, except with ``in_ring``: ``q`` and
        the command are then copied into the ring's slot only, which the entry reads (no
        arrays of its own: ``q`` may be the caller's, the compiled step's buffer is reused
        by its next step)."""
        cmds, ring = self._cmds, self._ring
        count = len(cmds)
        if count and t < cmds[-1][0]:
            self._ordered = False
        if count == ring.cap:
            ring.grow(count)
        slot = (ring.head + count) % ring.cap
        ring.t_items[slot] = t  # ring.t[slot] = t, without numpy's scalar indexing
        ring.has_items[slot] = False
        if q.shape[0] != ring.n:
            ring.joints(q.shape[0])
        q_row = ring.q_rows[slot]
        q_row[...] = q  # ring.q[slot] = q, through a view made once
        row = ring.qdot_rows[slot]
        row[...] = qdot if part is None else qdot[part]
        entry = (t, q_row, row, None) if in_ring else (t, q, qdot, part)
        cmds.append(_new_command(_Command, entry))
        oldest = t - self.horizon
        while cmds[0][0] < oldest:
            cmds.popleft()
            ring.head = (ring.head + 1) % ring.cap

    def motion(
        self, stamp: float, now: float, robot: tuple[object, ...] | None = None
    ) -> FloatArray:
        """``Σ_k J(q_k) q̇_k · |[t_k, t_k + T) ∩ [stamp, now)|`` (6,): the camera's
        displacement (m, rad) the commands made between ``stamp`` and ``now`` (s).
        ``robot``: the pack of the model robot's compiled kinematics
        (:mod:`redservo.robots.pack`, the same ``J`` as :attr:`jacobian`), or None."""
        cmds, ring = self._cmds, self._ring
        where = (ring.head, len(cmds), self._ordered)
        args = (ring.t, ring.twist, ring.has, where, self.period, float(stamp), float(now), _EPS)
        if robot is not None:  # the missing twists and the sum in one call
            return np.asarray(_K.robot_motion(*args, ring.q, ring.qdot, robot))
        total, missing = _K.motion(*args)
        if len(missing):  # their twists, kept for the next steps; then the whole sum
            cap = ring.t.shape[0]
            for i in missing.tolist():
                cmd = cmds[i]
                twist = self.jacobian(cmd.q) @ cmd.qdot
                cmds[i] = _new_command(_Command, (*cmd[:4], twist))
                slot = (ring.head + i) % cap
                ring.twist[slot] = twist
                ring.has[slot] = True
            total = _K.motion(*args)[0]
        return np.asarray(total)


class _Ring:
    """The history's times (s), twists (m/s, rad/s), joints and commands (rad or m, rad/s
    or m/s) by slot, and which twists are known (module docstring of
    :mod:`redservo.kernels.latency`)."""

    def __init__(self, cap: int, n: int = 0) -> None:
        self.t = np.zeros(cap)
        self.twist = np.zeros((cap, 6))
        self.has = np.zeros(cap, dtype=np.bool_)
        self.head = 0
        self.cap = cap
        self.joints(n)
        # t and has item by item (one slot written per command; typed Any: the stubs know
        # neither an ndarray as a buffer nor a memoryview's item assignment)
        self.t_items: Any = memoryview(self.t)  # type: ignore[arg-type]
        self.has_items: Any = memoryview(self.has)  # type: ignore[arg-type]

    def joints(self, n: int) -> None:
        """Slots for ``n`` joints (the first command's; a history holds one robot's), with
        a view of each slot's row (written once per command)."""
        cap = self.t.shape[0]
        self.q, self.qdot, self.n = np.zeros((cap, n)), np.zeros((cap, n)), n
        self.q_rows, self.qdot_rows = list(self.q), list(self.qdot)

    def grow(self, count: int) -> None:
        """Twice the slots, the ``count`` commands kept moved to the first ones."""
        cap, n = self.t.shape[0], self.q.shape[1]
        order = (self.head + np.arange(count)) % cap
        kept = (self.t[order], self.twist[order], self.has[order])
        q, qdot = self.q[order], self.qdot[order]
        self.__init__(2 * cap, n)  # type: ignore[misc]
        self.t[:count], self.twist[:count], self.has[:count] = kept
        self.q[:count], self.qdot[:count] = q, qdot


def present(
    task: VisualTask,
    history: CommandHistory,
    measurement: Features,
    t: float,
    s: FloatArray,
    depth_scale: float,
    engine: CompiledControl | None = None,
) -> Features:
    """``measurement`` (features ``s`` (k,) checked) brought from its stamp to ``t`` (s) by
    the module docstring's ``ŝ(t)``; itself when it has no ``stamp`` (or None) or is of ``t``.
    ``engine``: the controller's compiled engine (a task of image points), whose inverse
    depths and compiled ``L`` give the same ``ŝ`` in one call
    (:func:`redservo.kernels.latency.present_points`).

    Raises:
        ShapeError: the stamp is not a finite number, or is later than ``t`` (a measurement
            used before it exists).
    """
    stamp = getattr(measurement, "stamp", None)
    if stamp is None:
        return measurement
    stamp = as_time(stamp, "measurement.stamp")
    if stamp > t + _EPS:
        raise ShapeError(
            f"measurement.stamp {stamp:g} s is later than the step's t = {t:g} s: a "
            "measurement cannot be used before its image exists",
            argument="measurement.stamp",
        )
    if stamp >= t - _EPS:
        return measurement
    iz = None if engine is None else engine._inverse_depths(measurement.inv_depth)
    if iz is not None and iz.flags.carray and s.flags.carray:  # points: nothing to linearise
        assert engine is not None  # iz comes from it
        robot = engine.robot if engine.kernel is not None else None  # compiled kinematics
        s_now = _K.present_points(s, iz, history.motion(stamp, t, robot))
    else:
        L = task.interaction(s, measurement.inv_depth, depth_scale=depth_scale)
        s_now = s + L @ history.motion(stamp, t)
        _linearise_at_measured(task, s_now, s)
    return Measurement(s_now, tuple(measurement.inv_depth), t)


def _linearise_at_measured(task: VisualTask, s_now: FloatArray, s: FloatArray) -> None:
    """Tell each feature whose interaction matrix needs more than its value (the moment
    features' image moments) that ``s_now`` is a prediction from the measured ``s``."""
    at = 0
    for term in task.terms:
        size = term.feature.size
        keep = getattr(term.feature, "predicted", None)
        if keep is not None:
            keep(s_now[at : at + size], s[at : at + size])
        at += size
