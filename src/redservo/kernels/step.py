"""A whole control step in compiled code: kinematics, features, ``J1``, law and safety.

These kernels are what a batched closed loop calls for each sample (the simulator's
``simulate`` runs the same kernels one object at a time). A law is selected by its id
(:data:`LAW_IDS`) and its options are packed by
:func:`redservo.redundancy.kio.law_options` into a float array ``fopt`` and an int
array ``iopt`` (layout below); ``vopt`` (2, n) holds per-joint options (``sns``'s
``v_max`` and ``a_max``, inf when absent). ``qp`` is not here: its solver is a Python
library (the law calls the kernels of :mod:`redservo.kernels.bounded` around it).

Option layout, common to every law: ``fopt[0]`` rcond, ``fopt[1]`` the robust filter
threshold ε (0 when ``robust`` is off), ``iopt[0]`` shield, ``iopt[1]`` secondary-first
scaling; then per law (index: meaning):

* gpm: f2 α · gpm-auto: f2 α_max (inf: none), i2 current rule, i3 robust
* iterative family: i2 smooth, f2 α of the e2 term (0: none), i3 max levels (-1: none),
  f3 constraint cut-off, f4 constraint filter
* directional: f2 κ, i2 joint-limit force, f3 margin μ · wln: i2 history mode
* sns: f2 margin, i2 has v_max, i3 has a_max · large-projection: f2 e0, f3 e1, i2 mode,
  f4 ρ, f5 ρ1, f6 λ_tune, f7 P filter

Step outputs: the law's ``(q̇, iout, fout, axes, axf, vec)`` (:mod:`redservo.kernels.laws`)
with ``q̇`` after the safety layer, and ``sout`` (9,): the numbers of
:func:`redservo.kernels.safety.apply_safety` (non-finite count, scale, over-velocity,
dropped, shield change, shield acted, acceleration excess, exceeded) and, last, the law's
raw ``|q̇|∞``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.bounded import sns
from redservo.kernels.directional import directional, wln
from redservo.kernels.features import points_interaction, points_measure
from redservo.kernels.iterative import iterative
from redservo.kernels.kinematics import afma6_kinematics, dh_kinematics, matmul
from redservo.kernels.laws import classical, gpm, gpm_auto, new_outputs
from redservo.kernels.moments import (
    moment_features_interaction,
    moment_measure,
)
from redservo.kernels.projection import large_projection
from redservo.kernels.safety import apply_safety

__all__ = [
    "LAW_IDS",
    "afma6_moments",
    "afma6_moments_step",
    "afma6_points",
    "afma6_step",
    "dh_points",
    "dh_step",
    "inverse_transform",
    "law_step",
    "moments_task",
    "points_task",
]

LAW_IDS: dict[str, int] = {
    "classical": 0,
    "gpm": 1,
    "gpm-auto": 2,
    "iterative-basic": 3,
    "iterative": 4,
    "iterative-smooth": 5,
    "iterative-smooth-e2": 6,
    "directional": 7,
    "wln": 8,
    "sns": 9,
    "large-projection": 10,
}
"""Methods with a fully compiled step, and their ids."""
NS = 10


@kernel
def _raw_law(
    law_id: int,
    fopt: Any,
    iopt: Any,
    vopt: Any,
    J1: Any,
    e1: Any,
    e: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    prev: Any,
    has_prev: bool,
    hist: Any,
    has_hist: bool,
) -> Any:
    rc = fopt[0]
    rb = fopt[1]
    if law_id == 0:
        return classical(J1, e, lam, sec, has_sec, rc, rb)
    if law_id == 1:
        return gpm(J1, e, q, lp, lam, sec, has_sec, fopt[2], rc, rb)
    if law_id == 2:
        return gpm_auto(
            J1, e, q, lp, lam, dt, sec, has_sec, fopt[2], iopt[2] != 0, rc, rb, iopt[3] != 0
        )
    if law_id >= 3 and law_id <= 6:
        return iterative(
            J1,
            e,
            q,
            lp,
            lam,
            dt,
            sec,
            has_sec,
            iopt[2] != 0,
            fopt[2],
            iopt[3],
            rc,
            rb,
            fopt[3],
            fopt[4],
        )
    if law_id == 7:
        return directional(
            J1,
            e1,
            e,
            ff,
            has_ff,
            q,
            lp,
            lam,
            dt,
            sec,
            has_sec,
            fopt[2],
            iopt[2] != 0,
            fopt[3],
            rc,
            rb,
        )
    if law_id == 8:
        return wln(J1, e, q, lp, lam, sec, has_sec, iopt[2] != 0, hist, has_hist, rc, rb, 1e-9)
    if law_id == 9:
        out = sns(
            J1,
            e,
            q,
            lp,
            has_v,
            has_a,
            lam,
            dt,
            prev,
            has_prev,
            sec,
            has_sec,
            vopt[0],
            iopt[2] != 0,
            vopt[1],
            iopt[3] != 0,
            fopt[2],
            rc,
        )
        n = q.shape[0]
        qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
        for i in range(n):
            qdot[i] = out[0][i]
            axes[i] = 1 if out[2][i] else 0
        iout[0] = out[7]
        iout[2] = out[4]
        iout[3] = out[3]
        iout[4] = 1 if out[1] < 1.0 else 0
        iout[5] = 1 if out[5] else 0
        iout[6] = out[9]
        fout[2] = out[1]
        fout[3] = out[6]
        return qdot, iout, fout, axes, axf, vec
    return large_projection(
        J1,
        e1,
        e,
        q,
        lp,
        lam,
        sec,
        has_sec,
        fopt[2],
        fopt[3],
        iopt[2],
        fopt[4],
        fopt[5],
        fopt[6],
        rc,
        rb,
        fopt[7],
    )


@kernel
def law_step(
    law_id: int,
    fopt: Any,
    iopt: Any,
    vopt: Any,
    J1: Any,
    e1: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    prev: Any,
    has_prev: bool,
    hist: Any,
    has_hist: bool,
) -> Any:
    """One law call and its safety layer on plain arrays (module docstring)."""
    m = e1.shape[0]
    e = np.empty(m)
    for i in range(m):
        e[i] = e1[i] + ff[i] / lam if has_ff else e1[i]  # effective error, CM01 eq. 2
    qdot, iout, fout, axes, axf, vec = _raw_law(
        law_id, fopt, iopt, vopt, J1, e1, e, ff, has_ff, q, lp, has_v, has_a, lam, dt,
        sec, has_sec, prev, has_prev, hist, has_hist,
    )  # fmt: skip
    task = qdot
    first = iopt[1] != 0
    if first:
        task = classical(J1, e, lam, sec, False, fopt[0], fopt[1])[0]
    out, bad, s, over_v, dropped, change, acted, worst, exceeded = apply_safety(
        qdot, q, lp, has_v, has_a, dt, prev, has_prev, iopt[0] != 0, task, first
    )
    sout = np.empty(NS)
    sout[0] = bad
    sout[1] = s
    sout[2] = 1.0 if over_v else 0.0
    sout[3] = 1.0 if dropped else 0.0
    sout[4] = change
    sout[5] = 1.0 if acted else 0.0
    sout[6] = worst
    sout[7] = 1.0 if exceeded else 0.0
    big = 0.0
    for i in range(qdot.shape[0]):
        big = max(big, abs(qdot[i]))
    sout[8] = big
    sout[9] = 0.0
    return out, iout, fout, axes, axf, vec, sout


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
def afma6_points(
    q: Any,
    eMc: Any,
    cVe: Any,
    coupling: float,
    offset: float,
    bMo: Any,
    pts: Any,
    s_star: Any,
    C: Any,
) -> Any:
    """``(e1, J1)`` of an image-point task on the Afma6."""
    bMc, J = afma6_kinematics(q, eMc, cVe, coupling, offset)
    e1, J1, _, _ = points_task(bMc, J, bMo, pts, s_star, C)
    return e1, J1


@kernel
def dh_points(
    q: Any,
    par: Any,
    base: Any,
    flange: Any,
    standard: bool,
    eMc: Any,
    cVe: Any,
    bMo: Any,
    pts: Any,
    s_star: Any,
    C: Any,
) -> Any:
    """``(e1, J1)`` of an image-point task on a DH chain."""
    bMc, J = dh_kinematics(q, par, base, flange, standard, eMc, cVe)
    e1, J1, _, _ = points_task(bMc, J, bMo, pts, s_star, C)
    return e1, J1


@kernel
def afma6_moments(
    q: Any,
    eMc: Any,
    cVe: Any,
    coupling: float,
    offset: float,
    bMo: Any,
    pts: Any,
    area_star: float,
    depth_star: float,
    kind: int,
    s_star: Any,
) -> Any:
    """``(e1, J1)`` of the moment-feature task on the Afma6."""
    bMc, J = afma6_kinematics(q, eMc, cVe, coupling, offset)
    e1, J1, _, _ = moments_task(bMc, J, bMo, pts, area_star, depth_star, kind, s_star)
    return e1, J1


@kernel
def _after_task(
    e1: Any,
    J1: Any,
    q: Any,
    law_id: int,
    fopt: Any,
    iopt: Any,
    vopt: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
) -> Any:
    z = np.zeros(q.shape[0])
    return law_step(
        law_id, fopt, iopt, vopt, J1, e1, e1, False, q, lp, has_v, has_a, lam, dt,
        z, False, prev, has_prev, z, False,
    )  # fmt: skip


@kernel
def afma6_step(
    q: Any,
    eMc: Any,
    cVe: Any,
    coupling: float,
    offset: float,
    bMo: Any,
    pts: Any,
    s_star: Any,
    C: Any,
    law_id: int,
    fopt: Any,
    iopt: Any,
    vopt: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
) -> Any:
    """A full image-point step on the Afma6: kinematics, features, ``J1``, law, safety."""
    e1, J1 = afma6_points(q, eMc, cVe, coupling, offset, bMo, pts, s_star, C)
    return _after_task(
        e1, J1, q, law_id, fopt, iopt, vopt, lp, has_v, has_a, lam, dt, prev, has_prev
    )


@kernel
def dh_step(
    q: Any,
    par: Any,
    base: Any,
    flange: Any,
    standard: bool,
    eMc: Any,
    cVe: Any,
    bMo: Any,
    pts: Any,
    s_star: Any,
    C: Any,
    law_id: int,
    fopt: Any,
    iopt: Any,
    vopt: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
) -> Any:
    """A full image-point step on a DH chain (e.g. the Panda)."""
    e1, J1 = dh_points(q, par, base, flange, standard, eMc, cVe, bMo, pts, s_star, C)
    return _after_task(
        e1, J1, q, law_id, fopt, iopt, vopt, lp, has_v, has_a, lam, dt, prev, has_prev
    )


@kernel
def afma6_moments_step(
    q: Any,
    eMc: Any,
    cVe: Any,
    coupling: float,
    offset: float,
    bMo: Any,
    pts: Any,
    area_star: float,
    depth_star: float,
    kind: int,
    s_star: Any,
    law_id: int,
    fopt: Any,
    iopt: Any,
    vopt: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
) -> Any:
    """A full moment-feature step on the Afma6."""
    e1, J1 = afma6_moments(
        q, eMc, cVe, coupling, offset, bMo, pts, area_star, depth_star, kind, s_star
    )
    return _after_task(
        e1, J1, q, law_id, fopt, iopt, vopt, lp, has_v, has_a, lam, dt, prev, has_prev
    )
