"""The one form in which a robot enters the compiled engine (:mod:`redservo.kernels.robot`).

A robot with compiled kinematics packs itself (:meth:`redservo.robots.Robot.kernel_pack`)
into one tuple of fixed layout, whatever its kind, so that every driver of the step kernel
(the :class:`~redservo.control.Controller`, the campaign loop, the benchmarks) takes the
same pack and the same kind code:

``(kind, eMc, cVe, coupling, offset, par, base, flange, standard, frames, joints)``

* ``kind``: :data:`AFMA6` (0), :data:`DH` (1) or :data:`CHAIN` (2, fixed transforms and joint
  axes: every URDF robot);
* ``eMc`` (4, 4) the hand-eye transform (m) and ``cVe`` (6, 6) its twist transform;
* ``coupling``, ``offset``: the Afma6's wrist coupling and offset (0 for the other kinds);
* ``par`` (8, n), ``base``, ``flange`` (4, 4), ``standard``: a DH table
  (:mod:`redservo.kernels.kinematics`);
* ``frames`` (n + 1, 3, 4), ``joints`` (n, 4): a chain (:mod:`redservo.kernels.chain`).

The parts of the other kinds are placeholders of the same numba types, so one compiled
signature serves every robot of a given joint count.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo._validation import FloatArray

__all__ = ["AFMA6", "CHAIN", "DH", "KIND_NAMES", "RobotPack", "robot_pack"]

AFMA6, DH, CHAIN = 0, 1, 2
"""Kind codes of the pack."""
KIND_NAMES = {AFMA6: "afma6", DH: "dh", CHAIN: "chain"}

RobotPack = tuple[Any, ...]


def robot_pack(
    kind: int,
    n: int,
    eMc: FloatArray,
    cVe: FloatArray,
    *,
    coupling: float = 0.0,
    offset: float = 0.0,
    dh: tuple[FloatArray, FloatArray, FloatArray, bool] | None = None,
    chain: tuple[FloatArray, FloatArray] | None = None,
) -> RobotPack:
    """The pack of a robot of ``kind`` with ``n`` joints (module docstring); ``dh`` is
    ``(par, base, flange, standard)``, ``chain`` is ``(frames, joints)``."""
    c = np.ascontiguousarray
    par, base, flange, standard = dh or (np.zeros((8, n)), np.eye(4), np.eye(4), False)
    frames, joints = chain or (np.zeros((1, 3, 4)), np.zeros((0, 4)))
    return (
        kind,
        c(eMc, dtype=np.float64),
        c(cVe, dtype=np.float64),
        float(coupling),
        float(offset),
        c(par, dtype=np.float64),
        c(base, dtype=np.float64),
        c(flange, dtype=np.float64),
        bool(standard),
        c(frames, dtype=np.float64),
        c(joints, dtype=np.float64),
    )
