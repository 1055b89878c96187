"""Visual tasks and whole steps in compiled code: kinematics, features, ``J1``, law, safety.

``*_points``/``*_moments`` return ``(e1, J1)`` for a robot and an image-point or moment
task (current depth; CM01 eq. 25 combination ``C``); ``*_step`` adds the law and its
safety layer through :func:`redservo.kernels.step.law_step` and writes into the caller's
float buffer ``out`` (:func:`output_size`): ``q̇`` (n), the law's
integer outputs ``iout`` (16), its ``fout`` (16), the safety numbers ``sout`` (11) and
the level of each axis (n). Filling a buffer instead of returning arrays saves the
boxing of seven arrays (several µs) on every call from Python.

Arguments travel as packs, plain tuples unpacked by name at the top of each kernel (a
NamedTuple would cost numba a slow type lookup per call): ``robot`` as in
:mod:`redservo.kernels.control` (Afma6 ``(eMc, cVe, coupling, offset)``, DH ``(par, base,
flange, standard, eMc, cVe)``), ``task`` ``(bMo, pts, s_star, C)`` for points or ``(bMo,
pts, area*, depth*, kind, s_star)`` for moments, ``law`` ``(law_id, fopt, iopt, vopt)``
(:mod:`redservo.kernels.lawopts`), ``limits`` ``(rows, has_v, has_a)``.
:func:`redservo.binding.compiled_step` packs these arguments from the public objects.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.features import points_interaction, points_measure
from redservo.kernels.kinematics import afma6_kinematics, dh_kinematics, matmul
from redservo.kernels.moments import moment_features_interaction, moment_measure
from redservo.kernels.step import law_step

__all__ = [
    "afma6_moments",
    "afma6_moments_step",
    "afma6_points",
    "afma6_step",
    "dh_points",
    "dh_step",
    "inverse_transform",
    "moments_task",
    "output_size",
    "points_task",
    "write_outputs",
]


@kernel
def inverse_transform(T: Any) -> Any:
    """Inverse of a 4x4 rigid transform (``R^T``, ``-R^T t``)."""
    out = np.zeros((4, 4))
    for i in range(3):
        for j in range(3):
            out[i, j] = T[j, i]
        out[i, 3] = -(T[0, i] * T[0, 3] + T[1, i] * T[1, 3] + T[2, i] * T[2, 3])
    out[3, 3] = 1.0
    return out


@kernel
def points_task(bMc: Any, J: Any, bMo: Any, pts: Any, s_star: Any, C: Any) -> Any:
    """``(e1, J1, s, bad)`` of N image points (current depth): ``e1 = C (s - s*)``,
    ``J1 = C L J`` (CM01 eq. 25); ``bad`` the first point behind the camera (-1: none)."""
    cMo = matmul(inverse_transform(bMc), bMo)
    s, iz, bad = points_measure(cMo, pts)
    L = points_interaction(s, iz)
    k = s.shape[0]
    e = np.empty(k)
    for i in range(k):
        e[i] = s[i] - s_star[i]
    CL = matmul(C, L)
    m = C.shape[0]
    e1 = np.zeros(m)
    for i in range(m):
        for j in range(k):
            e1[i] += C[i, j] * e[j]
    return e1, matmul(CL, J), s, bad


@kernel
def moments_task(
    bMc: Any,
    J: Any,
    bMo: Any,
    pts: Any,
    area_star: float,
    depth_star: float,
    kind: int,
    s_star: Any,
) -> Any:
    """``(e1, J1, s, code)`` of the six moment features (α error wrapped to (-π/2, π/2])."""
    cMo = matmul(inverse_transform(bMc), bMo)
    s, plane, xg, yg, mu, code, _ = moment_measure(pts, cMo, area_star, depth_star, kind)
    e1 = np.zeros(6)
    if code != 0:
        return e1, np.zeros((6, J.shape[1])), s, code
    L = moment_features_interaction(pts.shape[0], xg, yg, mu, plane, area_star, depth_star, kind)
    for i in range(6):
        e1[i] = s[i] - s_star[i]
    d = 2.0 * e1[3]
    e1[3] = 0.5 * (np.pi - np.mod(np.pi - d, 2.0 * np.pi))
    return e1, matmul(L, J), s, code


@kernel
def afma6_points(q: Any, robot: Any, task: Any) -> Any:
    """``(e1, J1)`` of an image-point task on the Afma6 (packs in the module docstring)."""
    eMc, cVe, coupling, offset = robot
    bMo, pts, s_star, C = task
    bMc, J = afma6_kinematics(q, eMc, cVe, coupling, offset)
    e1, J1, _, _ = points_task(bMc, J, bMo, pts, s_star, C)
    return e1, J1


@kernel
def dh_points(q: Any, robot: Any, task: Any) -> Any:
    """``(e1, J1)`` of an image-point task on a DH chain."""
    par, base, flange, standard, eMc, cVe = robot
    bMo, pts, s_star, C = task
    bMc, J = dh_kinematics(q, par, base, flange, standard, eMc, cVe)
    e1, J1, _, _ = points_task(bMc, J, bMo, pts, s_star, C)
    return e1, J1


@kernel
def afma6_moments(q: Any, robot: Any, task: Any) -> Any:
    """``(e1, J1)`` of the moment-feature task on the Afma6."""
    eMc, cVe, coupling, offset = robot
    bMo, pts, area_star, depth_star, kind, s_star = task
    bMc, J = afma6_kinematics(q, eMc, cVe, coupling, offset)
    e1, J1, _, _ = moments_task(bMc, J, bMo, pts, area_star, depth_star, kind, s_star)
    return e1, J1


@kernel
def _after_task(
    e1: Any,
    J1: Any,
    q: Any,
    law: Any,
    limits: Any,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
    out: Any,
) -> None:
    """Run the law and its safety layer on ``(e1, J1)``; fill ``out`` (module docstring)."""
    none = q[:0]
    inputs = (e1[:0], none, prev if has_prev else none, none)
    qdot, iout, fout, axes, _, _, sout = law_step(law, limits, (lam, dt), J1, e1, q, inputs)
    write_outputs(out, qdot, iout, fout, sout, axes)


@kernel
def write_outputs(out: Any, qdot: Any, iout: Any, fout: Any, sout: Any, axes: Any) -> None:
    """Fill the step's output buffer ``out`` (layout :func:`output_size`)."""
    n = qdot.shape[0]
    k = 0
    for i in range(n):
        out[k] = qdot[i]
        k += 1
    for i in range(iout.shape[0]):
        out[k] = iout[i]
        k += 1
    for i in range(fout.shape[0]):
        out[k] = fout[i]
        k += 1
    for i in range(sout.shape[0]):
        out[k] = sout[i]
        k += 1
    for i in range(n):
        out[k] = axes[i]
        k += 1


def output_size(n: int) -> int:
    """Length of a step's output buffer for n joints: ``q̇`` (n), the law's ``iout`` (16,
    as floats), ``fout`` (16), the safety numbers ``sout`` (11), the per-axis levels (n)."""
    return 2 * n + 16 + 16 + 11


@kernel
def afma6_step(
    q: Any,
    robot: Any,
    task: Any,
    law: Any,
    limits: Any,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
    out: Any,
) -> None:
    """A full image-point step on the Afma6: kinematics, features, ``J1``, law, safety."""
    e1, J1 = afma6_points(q, robot, task)
    _after_task(e1, J1, q, law, limits, lam, dt, prev, has_prev, out)


@kernel
def dh_step(
    q: Any,
    robot: Any,
    task: Any,
    law: Any,
    limits: Any,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
    out: Any,
) -> None:
    """A full image-point step on a DH chain (e.g. the Panda)."""
    e1, J1 = dh_points(q, robot, task)
    _after_task(e1, J1, q, law, limits, lam, dt, prev, has_prev, out)


@kernel
def afma6_moments_step(
    q: Any,
    robot: Any,
    task: Any,
    law: Any,
    limits: Any,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
    out: Any,
) -> None:
    """A full moment-feature step on the Afma6."""
    e1, J1 = afma6_moments(q, robot, task)
    _after_task(e1, J1, q, law, limits, lam, dt, prev, has_prev, out)
