"""The scene and the task as the compiled ideal sensor takes them (:mod:`redservo.kernels.loop_task`).

:func:`scene_pack` and :func:`task_pack` turn a static or waypoint scene of point sets and a
task of image points and moment features into the tuples of plain arrays of
:mod:`redservo.kernels.loop_task` (layouts there); the campaign loop
(:mod:`redservo.campaign.looppack`) and the benchmarks' timing of its iteration
(:mod:`redservo.bench.sensed`) use them. The robot packs itself (:meth:`redservo.robots.Robot.kernel_pack`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np

if TYPE_CHECKING:
    from redservo.camera import Camera
    from redservo.scene import Scene
    from redservo.task import VisualTask

__all__ = ["scene_pack", "scene_targets", "task_pack"]


def scene_targets(task: VisualTask) -> list[str]:
    """The task's targets, in the order of the scene pack (sorted names)."""
    return sorted({term.target for term in task.terms})


def scene_pack(
    scene: Scene, task: VisualTask, cam: Camera, margin_px: float, check: bool
) -> tuple[Any, ...]:
    """The scene pack of :mod:`redservo.kernels.loop_task`: the targets' static poses or
    waypoints, their points (image check) and the camera."""
    from redservo.scene import PointSet, Waypoints
    from redservo.spatial import inverse

    targets = scene_targets(task)
    objs = [cast(PointSet, scene.object(name)) for name in targets]
    pts = [np.asarray(o.points, np.float64) for o in objs]
    vis = np.zeros((len(pts), max(p.shape[0] for p in pts), 3))
    for i, p in enumerate(pts):
        vis[i, : p.shape[0]] = p
    cnt = np.array([p.shape[0] for p in pts], dtype=np.int64)
    camera = np.array(
        [cam.px, cam.py, cam.u0, cam.v0, cam.width, cam.height, margin_px], dtype=float
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
    return (
        inverse(scene.wMb),
        wMo,
        vis,
        cnt,
        camera,
        bool(check),
        moving,
        times,
        w_cnt,
        w_poses,
        w_rot,
    )


def task_pack(task: VisualTask, depth_scale: float) -> tuple[Any, ...]:
    """The task pack of :mod:`redservo.kernels.loop_task`: the terms (image points and
    moment features), ``s*``, ``C`` and the depth factor."""
    from redservo.features.moments import _KIND, MomentFeatures
    from redservo.kernels.loop_task import MOMENTS, POINT

    index = {name: i for i, name in enumerate(scene_targets(task))}
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
    C = np.zeros((0, 0)) if task.C is None else np.ascontiguousarray(task.C, dtype=np.float64)
    s_star = np.ascontiguousarray(task.s_star, dtype=np.float64)
    has_C, scale = task.C is not None, float(depth_scale)
    return (kind, obj, pt, aux, m_pts, m_cnt, m_opt, s_star, C, has_C, scale)
