"""The step kernel: one compiled control step that every loop drives (docs/architecture.md).

The step is CM01 eq. 25 (``e1 = C (s − s*)``, ``J1 = C L J``, written here once,
:func:`task_rows`) followed by :func:`law_core`: the input check, the law and its safety
layer (:func:`redservo.kernels.step.law_step`) and the events of both
(:func:`~redservo.kernels.step.law_events`, :func:`~redservo.kernels.step.sout_events`).
Its drivers: the :class:`~redservo.control.Controller` (hence ``simulate`` and the servo
loop) through :func:`measured_control` (the model Jacobian given) and :func:`robot_control`
(the robot's compiled kinematics, :func:`redservo.kernels.robot.robot_kinematics`), on the
*measured* points; the campaign loop (:mod:`redservo.campaign.loop_kernel`), on the ideal
sensor of :mod:`redservo.kernels.sensed`; a law object's call (:func:`law_into`,
:mod:`redservo.redundancy.kernel_call`). Products by BLAS (``np.dot``), as numpy's ``@`` on
the object path, so that every driver agrees with the object path to the last bit. (Every
compiled layer links its callees' code again: a wrapper kernel costs seconds of a cold
compile, so the drivers call these kernels directly.)

Arguments travel as packs (plain tuples, unpacked by name at the top of each kernel; a
NamedTuple would cost numba a slow type lookup on every call):

* ``robot``: the robot pack of :mod:`redservo.robots.pack` (one layout and kind code for
  the Afma6, DH chains and chains of fixed transforms and axes such as URDF robots);
* ``meas``: ``(s, iz, s_star, C)``: the measured points (2N,), their inverse depths (N,)
  (1/m, already scaled by the controller's depth option), ``s*`` and the combination
  matrix ``C`` (m, 2N), or a (0, 0) array for none (``e1 = e``, ``J1 = L J``);
* ``law``: ``(law_id, fopt, iopt, vopt)`` (:mod:`redservo.kernels.lawopts`);
* ``limits``: ``(rows, has_v, has_a)`` (:mod:`redservo.kernels.pack`);
* ``ff`` (m,) the feed-forward ``∂e1/∂t`` and ``sec`` (n,) the secondary command, each
  empty (length 0) when absent; ``prev`` (n,) the previous command when ``has_prev`` (any
(n,) array otherwise).

The float buffer ``buf`` (:func:`control_layout`) receives ``q̇`` (n), ``iout`` (16),
``fout`` (16), ``sout`` (11), ``axes`` (n), ``axf`` (n), the law's and the safety layer's
event values and sources (4 × 20), ``e`` (2N), ``e1`` (m), ``J1`` (m·n), ``L`` (2N·6) and
a copy of ``q`` (n) (:func:`put_task`: the step's own joints, which its diagnostics read
when the safety layer acted, with no copy made in Python).
The Controller's kernels return ``(law mask, safety mask, vec)``, or a law mask of -1 when an input
fails :func:`~redservo.kernels.inputs.inputs_ok` (NaN or inf, a joint outside its limits):
the caller then takes the object path, whose checks name the input. Units: seconds,
metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.features import points_interaction
from redservo.kernels.flagbits import N_FLAGS
from redservo.kernels.inputs import inputs_ok
from redservo.kernels.robot import robot_kinematics
from redservo.kernels.step import NS, law_events, law_step, sout_events

__all__ = [
    "control_layout",
    "law_core",
    "law_into",
    "measured_control",
    "put_task",
    "robot_control",
    "task_rows",
]

NI, NF = 16, 16
"""Sizes of the law's ``iout`` and ``fout`` (:mod:`redservo.kernels.laws`)."""


def control_layout(n: int, m: int, k: int) -> dict[str, tuple[int, int]]:
    """``{name: (start, stop)}`` of the buffer of a step with n joints, m task rows and k
    point coordinates (module docstring); ``"size"`` gives its length."""
    names = "qdot iout fout sout axes axf lvals lsrc svals ssrc e e1 J1 L q".split()
    lengths = (n, NI, NF, NS, n, n, N_FLAGS, N_FLAGS, N_FLAGS, N_FLAGS, k, m, m * n, 6 * k, n)
    sizes = zip(names, lengths, strict=True)
    out: dict[str, tuple[int, int]] = {}
    at = 0
    for name, size in sizes:
        out[name] = (at, at + size)
        at += size
    out["size"] = (0, at)
    return out


@kernel
def _put(buf: Any, at: int, x: Any) -> int:
    """Copy the flat values of ``x`` into ``buf`` from ``at``; return the next index."""
    flat = x.ravel()
    for i in range(flat.shape[0]):
        buf[at + i] = flat[i]
    return at + flat.shape[0]


@kernel
def task_rows(e: Any, L: Any, C: Any, J: Any) -> Any:
    """CM01 eq. 25, the one place it is computed: ``(e1, J1)`` with ``e1 = C e`` (m,) and
    ``J1 = (C L) J`` (m, n), from the error ``e = s − s*`` (k,), the interaction matrix
    ``L`` (k, 6) and the robot Jacobian ``J = cVe eJe`` (6, n); ``C`` (m, k), or a (0, 0)
    array for none (``e1 = e``, ``J1 = L J``). Products by BLAS (``np.dot``), as numpy's
    ``C @ e`` and ``(C @ L) @ J`` on the object path, so both agree to the last bit."""
    if C.shape[0] == 0:
        return e.copy(), np.dot(L, J)
    return np.dot(C, e), np.dot(np.dot(C, L), J)


@kernel
def law_core(q: Any, J1: Any, e1: Any, law: Any, limits: Any, gains: Any, inputs: Any) -> Any:
    """The input check, the law and its safety layer
    (:func:`~redservo.kernels.step.law_step`) and the events of both, on ``J1`` (m, n) and
    ``e1`` (m,); ``q`` (n,); ``law``, ``limits``, ``gains`` as ``law_step`` takes them;
    ``inputs`` ``(ff, sec, prev, hist)``, each empty when absent.

    Returns:
        ``(ok, (q̇, iout, fout, axes, axf, vec, sout), (lmask, lvals, lsrc), (smask, svals,
        ssrc))``; ``ok`` False when an input fails :func:`~redservo.kernels.inputs.inputs_ok`
        (the law is then not called and the other outputs are empty: the caller takes the
        object path, whose checks name the input).
    """
    ff, sec, prev, _ = inputs
    if not inputs_ok(J1, e1, q, limits[0], ff, sec, prev):
        z = e1[:0]
        zi = np.zeros(0, dtype=np.int64)
        return False, (z, zi, z, zi, z, z, z), (0, z, zi), (0, z, zi)
    qdot, iout, fout, axes, axf, vec, sout = law_step(law, limits, gains, J1, e1, q, inputs)
    lev = law_events(law[0], law[1], e1.shape[0], iout, fout, axes, axf, vec)
    return True, (qdot, iout, fout, axes, axf, vec, sout), lev, sout_events(sout)


@kernel
def _put_law(buf: Any, out: Any, lev: Any, sev: Any) -> int:
    """Write :func:`law_core`'s outputs into ``buf`` in the order of :func:`control_layout`
    (``qdot`` to ``ssrc``); return the next index."""
    qdot, iout, fout, axes, axf, _, sout = out
    at = 0
    for x in (qdot, iout.astype(np.float64), fout, sout):
        at = _put(buf, at, x)
    at = _put(buf, at, axes.astype(np.float64))
    at = _put(buf, at, axf)
    for x in (lev[1], lev[2].astype(np.float64), sev[1], sev[2].astype(np.float64)):
        at = _put(buf, at, x)
    return at


@kernel
def law_into(
    q: Any, J1: Any, e1: Any, law: Any, limits: Any, gains: Any, inputs: Any, buf: Any
) -> Any:
    """:func:`law_core` with its outputs written into ``buf`` (the first parts of
    :func:`control_layout`, ``qdot`` to ``ssrc``, then the law's ``vec`` right after them):
    ``(law mask, safety mask, len(vec))``, or a law mask of -1 when an input fails the
    check, a length of -1 when ``buf`` has no room for ``vec`` (n (n + 1) entries always
    suffice). What a law object's call runs: one buffer it made, and three numbers back
    (numba boxes every array a kernel returns, ≈ 0.4 µs apiece)."""
    ok, out, lev, sev = law_core(q, J1, e1, law, limits, gains, inputs)
    if not ok:
        return -1, 0, 0
    at = _put_law(buf, out, lev, sev)
    vec = out[5]
    if at + vec.shape[0] > buf.shape[0]:
        return lev[0], sev[0], -1
    _put(buf, at, vec)
    return lev[0], sev[0], vec.shape[0]


@kernel
def put_task(buf: Any, at: int, e: Any, e1: Any, J1: Any, L: Any, q: Any) -> int:
    """Write the step's task parts and its joints into ``buf`` from ``at``, in the order
    of :func:`control_layout` (``e`` to ``q``); return the next index. The Controller's
    steps (:func:`measured_control`, :func:`redservo.kernels.qp_control.qp_measured_control`)
    call it after :func:`_put_law`."""
    for x in (e, e1):
        at = _put(buf, at, x)
    at = _put(buf, at, J1)
    at = _put(buf, at, L)
    return _put(buf, at, q)


@kernel
def points_rows(s: Any, iz: Any, s_star: Any, C: Any, J: Any) -> Any:
    """``(e, e1, L, J1)`` of N points at ``s`` (2N,) with the inverse depths ``iz`` (N,;
    1/m, as ``L`` uses them): ``L(s, 1/Ẑ)`` (2N, 6), ``e = s − s*`` (2N,) and CM01 eq. 25
    (:func:`task_rows`) with ``C`` (or an empty one: ``e1 = e``) and the model Jacobian ``J``
    (6, n); the one computation of the Controller's step and of the points' task kernel
    (:func:`redservo.kernels.points_task.points_task`)."""
    L = points_interaction(s, iz)
    k = s.shape[0]
    e = np.empty(k)
    for i in range(k):
        e[i] = s[i] - s_star[i]
    e1, J1 = task_rows(e, L, C, J)
    return e, e1, L, J1


@kernel
def measured_control(
    q: Any,
    J: Any,
    meas: Any,
    law: Any,
    limits: Any,
    gains: Any,
    inputs: Any,
    buf: Any,
) -> Any:
    """The Controller's step with the model Jacobian ``J`` (6, n) given (module docstring):
    ``L(s, 1/Ẑ)``, ``e``, CM01 eq. 25 (:func:`task_rows`), then the step kernel
    (:func:`law_core`), its results written into ``buf``. ``packs`` as
    :func:`robot_control`."""
    s, iz, s_star, C = meas
    e, e1, L, J1 = points_rows(s, iz, s_star, C, J)
    ff, sec, prev = inputs
    full = (ff, sec, prev, q[:0])
    ok, out, lev, sev = law_core(q, J1, e1, law, limits, gains, full)
    if not ok:
        return -1, 0, e[:0]  # the object path raises the error naming the input
    put_task(buf, _put_law(buf, out, lev, sev), e, e1, J1, L, q)
    return lev[0], sev[0], out[5]


@kernel
def robot_control(q: Any, robot: Any, *packs: Any) -> Any:
    """The Controller's step on a robot with compiled kinematics (``robot``: the pack of
    :mod:`redservo.robots.pack`); ``packs``: ``meas, law, limits, gains, inputs, buf``
    (module docstring)."""
    _, J = robot_kinematics(q, robot)
    return measured_control(q, J, *packs)
