"""The viewer's surfaces: a URDF robot's visual meshes and the target objects as they are.

* Robot: the ``<visual>`` geometry of a URDF robot (:func:`redservo.viewer.meshes.urdf_visuals`),
  each placed at ``bMl · lMv`` every frame (``bMl`` the link pose of the frame), in its
  material's colour at :data:`VISUAL_OPACITY` so that the links (purple sticks) and the joint
  axes coloured by their limits stay visible through the housings. A robot without a URDF
  file, or a link whose mesh file is missing, is drawn with the sticks only.
* Objects (``TARGET_COLOR``): a point set as its points, a fiducial tag as its white square
  with the black one on it (the tag's size), a sphere as a sphere, a cylinder as a cylinder of
  its radius (0.5 m long, centred on its point), a line as a segment.

Every function takes the viser server (or anything with its ``scene`` API) and the
:class:`~redservo.viewer.playback.Frame` to show; handles are kept in a list of
``(handle, how)`` pairs that :func:`place` moves.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.viewer.meshes import Visuals, cylinder_mesh, tag_meshes, urdf_visuals

if TYPE_CHECKING:  # pragma: no cover
    from redservo.viewer.playback import Frame, Playback

__all__ = ["VISUAL_OPACITY", "add_objects", "add_visuals", "place", "robot_visuals"]

VISUAL_OPACITY = 0.6
"""Opacity of the robot's visual meshes (the links and joint axes show through)."""
_DEFAULT_VISUAL = (200, 200, 205)
_WHITE, _BLACK = (245, 245, 245), (20, 20, 20)


def _wxyz(R: FloatArray) -> FloatArray:
    import viser.transforms as vtf

    return np.asarray(vtf.SO3.from_matrix(R).wxyz)


def robot_visuals(pb: Playback, links: set[str]) -> Visuals:
    """The visuals of ``pb``'s robot when it was read from a URDF file, else none."""
    path = getattr(pb.exp.robot, "path", None)
    return urdf_visuals(path, links) if path is not None else Visuals()


def add_visuals(server: Any, visuals: Visuals, fr: Frame) -> list[tuple[Any, Any]]:
    """Add the robot's visual meshes at frame ``fr``; returns ``(handle, (link, lMv))``."""
    out = []
    for i, vis in enumerate(visuals.visuals):
        T = fr.links[vis.link] @ vis.lMv
        handle = server.scene.add_mesh_simple(
            f"/robot/visual/{i}_{vis.link}",
            vis.vertices,
            vis.faces,
            color=vis.color or _DEFAULT_VISUAL,
            opacity=VISUAL_OPACITY,
            position=T[:3, 3],
            wxyz=_wxyz(T[:3, :3]),
        )
        out.append((handle, ("visual", vis.link, vis.lMv)))
    return out


def _cylinder_pose(seg: FloatArray) -> FloatArray:
    """Pose (4x4) of a z-axis cylinder on the segment ``seg`` (2, 3)."""
    d = seg[1] - seg[0]
    z = d / max(float(np.linalg.norm(d)), 1e-12)
    x = np.cross([0.0, 0.0, 1.0] if abs(z[2]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    T[:3, 3] = 0.5 * (seg[0] + seg[1])
    return T


def _tag_pose(corners: FloatArray) -> FloatArray:
    """Pose (4x4) of a tag from its four corners (4, 3), in AprilTag 3's order."""
    x = corners[1] - corners[0]
    x /= max(float(np.linalg.norm(x)), 1e-12)
    y = corners[3] - corners[0]
    y -= x * float(np.dot(x, y))
    y /= max(float(np.linalg.norm(y)), 1e-12)
    T = np.eye(4)
    T[:3, :3] = np.stack([x, y, np.cross(x, y)], axis=1)
    T[:3, 3] = corners.mean(axis=0)
    return T


def _pose_of(kind: str, geo: Any) -> FloatArray:
    return _tag_pose(np.asarray(geo)) if kind == "tag" else _cylinder_pose(geo[0])


def add_objects(
    server: Any, pb: Playback, fr: Frame, color: tuple[int, int, int], scale: float
) -> list[tuple[Any, Any]]:
    """Add the target objects at frame ``fr``; returns ``(handle, (kind, index))``."""
    from redservo.scene import Tag

    out: list[tuple[Any, Any]] = []
    scene = pb.exp.scene
    for j, (name, kind, geo) in enumerate(fr.objects):
        path = f"/objects/{name}"
        obj = scene.object(name)
        if isinstance(obj, Tag):
            T = _tag_pose(geo)
            for part, (v, f), c in zip(("white", "black"), tag_meshes(obj.size), (_WHITE, _BLACK)):
                h = server.scene.add_mesh_simple(
                    f"{path}/{part}",
                    v,
                    f,
                    color=c,
                    side="double",
                    position=T[:3, 3],
                    wxyz=_wxyz(T[:3, :3]),
                )
                out.append((h, ("tag", j)))
            h = server.scene.add_point_cloud(
                f"{path}/corners", geo.astype(np.float32), color, point_size=0.01 * scale
            )
            out.append((h, ("points", j)))
        elif kind == "points":
            h = server.scene.add_point_cloud(
                path, geo.astype(np.float32), color, point_size=0.02 * scale, point_shape="circle"
            )
            out.append((h, ("points", j)))
        elif kind == "sphere":
            h = server.scene.add_icosphere(
                path, radius=geo[1], color=color, position=geo[0], opacity=0.8
            )
            out.append((h, ("sphere", j)))
        elif kind == "cylinder":
            seg, radius = geo
            v, f = cylinder_mesh(max(float(radius), 1e-3), float(np.linalg.norm(seg[1] - seg[0])))
            T = _cylinder_pose(seg)
            h = server.scene.add_mesh_simple(
                path, v, f, color=color, opacity=0.8, position=T[:3, 3], wxyz=_wxyz(T[:3, :3])
            )
            out.append((h, ("cylinder", j)))
        else:
            h = server.scene.add_line_segments(
                path, geo[0][None], color, thickness=max(geo[1], 0.005) * 2
            )
            out.append((h, ("line", j)))
    return out


def place(handles: list[tuple[Any, Any]], fr: Frame) -> None:
    """Move every surface of ``handles`` to frame ``fr``."""
    for handle, how in handles:
        kind = how[0]
        if kind == "visual":
            T = fr.links[how[1]] @ how[2]
        elif kind in ("tag", "cylinder"):
            T = _pose_of(kind, fr.objects[how[1]][2])
        elif kind == "points":
            handle.points = fr.objects[how[1]][2].astype(np.float32)
            continue
        elif kind == "sphere":
            handle.position = fr.objects[how[1]][2][0]
            continue
        else:
            handle.points = fr.objects[how[1]][2][0][None].astype(np.float32)
            continue
        handle.position = T[:3, 3]
        handle.wxyz = _wxyz(T[:3, :3])
