"""The compiled step of a :class:`~redservo.control.Controller` on measured image points.

One call turns joint positions and *measured* points into the safe command and everything
the controller returns: kinematics of the robot, ``L(s, 1/Ẑ)``, ``e1 = C (s − s*)``,
``J1 = C L J`` (CM01 eq. 25; products by BLAS, ``np.dot``, as numpy's ``@`` on the object
path, so that both agree to the last bit, as the campaign loop of
:mod:`redservo.kernels.loop_task` does), the law and its safety layer
(:func:`redservo.kernels.step.law_step`) and the events of both
(:func:`~redservo.kernels.step.law_events`, :func:`~redservo.kernels.step.sout_events`).

Arguments travel as packs (plain tuples, unpacked by name at the top of each kernel; a
NamedTuple would cost numba a slow type lookup on every call):

* ``robot``: ``(eMc, cVe, coupling, offset)`` for the Afma6, ``(par, base, flange,
  standard, eMc, cVe)`` for a DH chain, ``(frames, joints, eMc, cVe)`` for a chain of fixed
  transforms and axes (URDF robots), as :mod:`redservo.kernels.kinematics` and
  :mod:`redservo.kernels.chain` take them;
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
event values and sources (4 × 20), ``e`` (2N), ``e1`` (m), ``J1`` (m·n) and ``L`` (2N·6).
The kernels return ``(law mask, safety mask, vec)``, or a law mask of -1 when an input
fails :func:`~redservo.kernels.inputs.inputs_ok` (NaN or inf, a joint outside its limits):
the caller then takes the object path, whose checks name the input. Units: seconds,
metres, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.chain import chain_kinematics
from redservo.kernels.features import points_interaction
from redservo.kernels.flagbits import N_FLAGS
from redservo.kernels.inputs import inputs_ok
from redservo.kernels.kinematics import afma6_kinematics, dh_kinematics
from redservo.kernels.step import NS, law_events, law_step, sout_events

__all__ = ["afma6_control", "chain_control", "control_layout", "dh_control"]

NI, NF = 16, 16
"""Sizes of the law's ``iout`` and ``fout`` (:mod:`redservo.kernels.laws`)."""


def control_layout(n: int, m: int, k: int) -> dict[str, tuple[int, int]]:
    """``{name: (start, stop)}`` of the buffer of a step with n joints, m task rows and k
    point coordinates (module docstring); ``"size"`` gives its length."""
    sizes = (
        ("qdot", n), ("iout", NI), ("fout", NF), ("sout", NS), ("axes", n), ("axf", n),
        ("lvals", N_FLAGS), ("lsrc", N_FLAGS), ("svals", N_FLAGS), ("ssrc", N_FLAGS),
        ("e", k), ("e1", m), ("J1", m * n), ("L", 6 * k),
    )  # fmt: skip
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
def _measured(
    q: Any,
    J: Any,
    meas: Any,
    law: Any,
    limits: Any,
    gains: Any,
    inputs: Any,
    buf: Any,
) -> Any:
    """The step after the kinematics (module docstring)."""
    s, iz, s_star, C = meas
    law_id, fopt = law[0], law[1]
    rows = limits[0]
    L = points_interaction(s, iz)
    k = s.shape[0]
    e = np.empty(k)
    for i in range(k):
        e[i] = s[i] - s_star[i]
    if C.shape[0] == 0:  # no combination matrix: e1 = e, J1 = L J
        e1 = e.copy()
        J1 = np.dot(L, J)
    else:  # BLAS, as numpy's ``C @ e`` and ``(C @ L) @ J`` on the object path
        e1 = np.dot(C, e)
        J1 = np.dot(np.dot(C, L), J)
    m = e1.shape[0]
    ff, sec, prev = inputs
    if not inputs_ok(J1, e1, q, rows, ff, sec, prev):
        return -1, 0, e[:0]  # the object path raises the error naming the input
    qdot, iout, fout, axes, axf, vec, sout = law_step(
        law, limits, gains, J1, e1, q, (ff, sec, prev, q[:0])
    )
    lmask, lvals, lsrc = law_events(law_id, fopt, m, iout, fout, axes, axf, vec)
    smask, svals, ssrc = sout_events(sout)
    at = 0
    for x in (qdot, iout.astype(np.float64), fout, sout):
        at = _put(buf, at, x)
    at = _put(buf, at, axes.astype(np.float64))
    at = _put(buf, at, axf)
    for x in (lvals, lsrc.astype(np.float64), svals, ssrc.astype(np.float64), e, e1):
        at = _put(buf, at, x)
    at = _put(buf, at, J1)
    _put(buf, at, L)
    return lmask, smask, vec


@kernel
def afma6_control(q: Any, robot: Any, *packs: Any) -> Any:
    """The Controller's step on the Afma6; ``packs``: ``meas, law, limits, gains, inputs,
    buf`` (module docstring)."""
    eMc, cVe, coupling, offset = robot
    _, J = afma6_kinematics(q, eMc, cVe, coupling, offset)
    return _measured(q, J, *packs)


@kernel
def dh_control(q: Any, robot: Any, *packs: Any) -> Any:
    """The Controller's step on a DH chain (``packs`` as :func:`afma6_control`)."""
    par, base, flange, standard, eMc, cVe = robot
    _, J = dh_kinematics(q, par, base, flange, standard, eMc, cVe)
    return _measured(q, J, *packs)


@kernel
def chain_control(q: Any, robot: Any, *packs: Any) -> Any:
    """The Controller's step on a chain of fixed transforms and axes (``packs`` as
    :func:`afma6_control`)."""
    frames, joints, eMc, cVe = robot
    _, J = chain_kinematics(q, frames, joints, eMc, cVe)
    return _measured(q, J, *packs)


@kernel
def given_control(q: Any, J: Any, *packs: Any) -> Any:
    """The Controller's step with the model Jacobian ``J`` (6, n) given by the caller
    (``packs`` as :func:`afma6_control`)."""
    return _measured(q, J, *packs)
