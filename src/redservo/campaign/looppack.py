"""What the compiled campaign loop covers, and the packs it takes (docs/scaling.md).

:func:`robot_reason` and :func:`scene_reason` say why an experiment's robot or task is not
covered by :func:`redservo.campaign.loop_kernel.closed_loop` (None: it is);
:func:`robot_args`, :func:`scene_args` and :func:`task_args` pack a covered experiment
into the tuples of plain arrays and numbers the loop takes (layouts:
:mod:`redservo.campaign.loop_kernel` for the robot, :mod:`redservo.kernels.loop_task` for
the scene and the task).
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np

from redservo.experiment import Experiment

__all__ = ["robot_args", "robot_reason", "scene_args", "scene_reason", "task_args"]


def robot_reason(exp: Experiment) -> str | None:
    """Why the loop has no kinematics for ``exp``'s robot (None: it has)."""
    from redservo.robots.afma6 import Afma6
    from redservo.robots.chain import ChainRobot
    from redservo.robots.dh import DHRobot

    kin = type(exp.robot).kinematics
    if kin not in (Afma6.kinematics, DHRobot.kinematics, ChainRobot.kinematics):
        return f"robot {type(exp.robot).__name__}: no compiled kinematics in the loop"
    return None


def scene_reason(exp: Experiment) -> str | None:
    """Why the loop cannot measure ``exp``'s task (None: it can)."""
    from redservo.features import PointFeature
    from redservo.features.moments import MomentFeatures
    from redservo.scene import PointSet, Static, Waypoints

    if exp.task.depth != "current":
        return f"depth = {exp.task.depth!r} (the compiled loop uses the current depth)"
    for term in exp.task.terms:
        if type(term.feature) not in (PointFeature, MomentFeatures):
            return (
                f"feature {type(term.feature).__name__}: only image points and moments are compiled"
            )
        obj = exp.scene.object(term.target)
        if not isinstance(obj, PointSet) or type(obj.trajectory) not in (Static, Waypoints):
            return f"object {term.target!r}: only point sets, static or on waypoints, are compiled"
    return None


def robot_args(exp: Experiment) -> tuple[Any, ...]:
    """The robot pack: ``(kind, eMc, cVe, coupling, offset, par, base, flange, standard,
    frames, joints)``, kind 0 the Afma6, 1 a DH chain, 2 a chain of fixed transforms."""
    from redservo.robots.afma6 import COUPLING, OFFSET, Afma6
    from redservo.robots.chain import ChainRobot

    r = exp.robot
    c = np.ascontiguousarray
    eMc, cVe = c(r.eMc, dtype=np.float64), c(r.cVe, dtype=np.float64)
    # the arrays of the kinds not taken: placeholders of the same numba types
    no_dh = (np.zeros((8, r.n)), np.eye(4), np.eye(4), False)
    no_chain = (np.zeros((1, 3, 4)), np.zeros((0, 4)))
    if isinstance(r, Afma6):
        return (0, eMc, cVe, COUPLING, OFFSET, *no_dh, *no_chain)
    if isinstance(r, ChainRobot):
        return (2, eMc, cVe, 0.0, 0.0, *no_dh, c(r.chain.frames), c(r.chain.joints))
    par, base, flange = r._par, r._base, r._flange  # type: ignore[attr-defined]
    standard = r._convention == "standard"  # type: ignore[attr-defined]
    return (1, eMc, cVe, 0.0, 0.0, c(par), c(base), c(flange), bool(standard), *no_chain)


def _targets(exp: Experiment) -> list[str]:
    """The task's targets, in the order of the scene pack (sorted names)."""
    return sorted({term.target for term in exp.task.terms})


def scene_args(exp: Experiment) -> tuple[Any, ...]:
    """The scene pack of :mod:`redservo.kernels.loop_task`: the targets' static poses or
    waypoints, their points (image check) and the camera."""
    from redservo.scene import PointSet, Waypoints
    from redservo.spatial import inverse

    scene, cam, opt = exp.scene, exp.camera, exp.options
    targets = _targets(exp)
    objs = [cast(PointSet, scene.object(name)) for name in targets]
    pts = [np.asarray(o.points, np.float64) for o in objs]
    vis = np.zeros((len(pts), max(p.shape[0] for p in pts), 3))
    for i, p in enumerate(pts):
        vis[i, : p.shape[0]] = p
    cnt = np.array([p.shape[0] for p in pts], dtype=np.int64)
    camera = np.array(
        [cam.px, cam.py, cam.u0, cam.v0, cam.width, cam.height, opt.image_margin_px], dtype=float
    )
    ways = [o.trajectory if type(o.trajectory) is Waypoints else None for o in objs]
    W = max([1] + [w.times.shape[0] for w in ways if w is not None])
    moving = np.array([w is not None for w in ways], dtype=np.bool_)
    times, w_cnt = np.zeros((len(objs), W)), np.ones(len(objs), dtype=np.int64)
    w_poses, w_rot = np.zeros((len(objs), W, 4, 4)), np.zeros((len(objs), W, 3))
    for i, w in enumerate(ways):
        if w is not None:
            k = w.times.shape[0]
            times[i, :k], w_poses[i, :k], w_cnt[i] = w.times, w.poses, k
            w_rot[i, : k - 1] = w._rotvecs
    wMo = np.array([scene.wMo(name, 0.0) for name in targets])
    check = bool(opt.check_image)
    return (inverse(scene.wMb), wMo, vis, cnt, camera, check, moving, times, w_cnt, w_poses, w_rot)


def task_args(exp: Experiment) -> tuple[Any, ...]:
    """The task pack of :mod:`redservo.kernels.loop_task`: the terms (image points and
    moment features), ``s*``, ``C`` and the depth factor."""
    from redservo.features.moments import _KIND, MomentFeatures
    from redservo.kernels.loop_task import MOMENTS, POINT

    task, opt = exp.task, exp.options
    index = {name: i for i, name in enumerate(_targets(exp))}
    K = len(task.terms)
    kind, obj, aux = (np.zeros(K, dtype=np.int64) for _ in range(3))
    pt = np.zeros((K, 3))
    moments: list[MomentFeatures] = []
    for j, term in enumerate(task.terms):
        obj[j] = index[term.target]
        f = term.feature
        if isinstance(f, MomentFeatures):
            kind[j], aux[j] = MOMENTS, len(moments)
            moments.append(f)
        else:
            kind[j], pt[j] = POINT, f.point_o  # type: ignore[attr-defined]
    P = max([1] + [f._points.shape[0] for f in moments])
    m_pts = np.zeros((max(len(moments), 1), P, 3))
    m_cnt = np.zeros(max(len(moments), 1), dtype=np.int64)
    m_opt = np.zeros((max(len(moments), 1), 3))
    for a, f in enumerate(moments):
        m_pts[a, : f._points.shape[0]], m_cnt[a] = f._points, f._points.shape[0]
        m_opt[a] = (f.desired_area, f.desired_depth, _KIND[f.rotation_features])
    C = np.eye(task.k) if task.C is None else np.ascontiguousarray(task.C, dtype=np.float64)
    s_star = np.ascontiguousarray(task.s_star, dtype=np.float64)
    has_C, scale = task.C is not None, float(opt.depth_scale)
    return (kind, obj, pt, aux, m_pts, m_cnt, m_opt, s_star, C, has_C, scale)
