"""The scene's objects as MuJoCo bodies: dots printed on paper, tags, spheres, cylinders, lines.

Each object is a *mocap* body (its pose is set, not simulated) placed at ``wMo(t)`` before
each frame is rendered, so moving targets move in the images too; with a camera fixed in the
world (eye-to-hand) each object is instead a body fixed to the arm's last link at ``eMo``,
moved by the physics (:func:`scene_bodies`' ``carrier``):

* a :class:`~redservo.scene.PointSet` whose points are coplanar is a sheet of white paper
  (1 mm thick, ``paper_margin`` beyond the dots) with matte black discs printed on both
  faces, centred on the points; the disc radius is a third of the smallest distance
  between two dots, at most 1 cm (a choice: large enough to be seen at a metre, small
  enough that the projected disc's centroid stays within a few hundredths of a pixel of
  the projected centre);
* a :class:`~redservo.scene.Tag` is its printed marker (OpenCV's bit pattern,
  :func:`redservo.vision.tag_render.tag_bits`, 32 texels per cell) on white paper one cell
  wider on every side, a texture on a 0.2 mm card whose ``+z`` face is the printed side of the
  tag frame (MuJoCo maps a 2-D texture's columns along the face's ``+x`` and its rows along
  ``−y``; the tag frame wants the marker's columns along ``−x`` and rows along ``+y``, so the
  marker image is turned by π);
* a :class:`~redservo.scene.Sphere` is a dark matte sphere, a
  :class:`~redservo.scene.Cylinder` a 2 m long dark matte cylinder along its axis
  (:data:`SHAPE_RGBA`: a clear edge against the lighter sky, arm and paper), both finely
  tessellated meshes (:mod:`redservo.physics.meshes`: outlines true to 0.01 px).

A :class:`~redservo.scene.Line` is a 2 m dark matte rod of radius :data:`LINE_ROD_RADIUS`
(the line is its axis). Other objects (non-coplanar point sets) are not drawn;
:func:`scene_bodies` says which in its ``skipped`` list, which
:class:`~redservo.physics.MujocoCamera` refuses when the task observes one.

Units: metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.features import object_adapter
from redservo.physics.meshes import cylinder_mesh, sphere_mesh
from redservo.physics.mjcf import _vec, xml_pose
from redservo.scene import Cylinder, Line, PointSet, Scene, Sphere, Tag
from redservo.vision.tag_render import tag_bits

__all__ = [
    "LINE_ROD_RADIUS",
    "PAPER_HALF_THICKNESS",
    "SHAPE_RGBA",
    "cylinder_geoms",
    "dot_radius",
    "line_geoms",
    "points_geoms",
    "scene_bodies",
    "set_poses",
    "sphere_geoms",
    "tag_texture",
]

_TEXELS_PER_CELL = 32

SHAPE_RGBA = "0.05 0.05 0.055 1"
"""Paint of the spheres and cylinders: dark and matte (no specular highlight), so that in
full light they stay below gray level 15 (ambient 0.2 + head light 0.25 + spot 0.5 of
reflectance 0.05), far from the sky (about 118) and the paper; their outline is an edge of
one sign whatever the shading and shadows (:mod:`redservo.physics.shapes`)."""

LINE_ROD_RADIUS = 0.005
"""Radius (m) of the rod that draws a :class:`~redservo.scene.Line`: 6 px wide at 1 m with
a 600 px focal length, wide enough for both its edges to be measured (a choice)."""

PAPER_HALF_THICKNESS = 0.0001
"""Half thickness of the paper (m): its faces are 0.1 mm from the dots' plane."""
_DOT_HALF = 0.00015  # the printed discs stand 0.05 mm proud of the paper's faces


def _plane(points: FloatArray) -> FloatArray | None:
    """A 4x4 frame (in the object frame) whose z = 0 plane holds the points, or None."""
    c = points.mean(axis=0)
    if len(points) < 3:
        # One or two dots: on the object's own z = const plane.
        M = np.eye(4)
        M[:3, 3] = c
        return M
    _, s, vt = np.linalg.svd(points - c)
    if s[-1] > 1e-6:
        return None
    normal = vt[2]
    if normal[2] < 0:
        normal = -normal
    x = vt[0] - normal * float(vt[0] @ normal)
    x /= np.linalg.norm(x)
    M = np.eye(4)
    M[:3, :3] = np.column_stack([x, np.cross(normal, x), normal])
    M[:3, 3] = c
    return M


def dot_radius(points: FloatArray) -> float:
    """Radius (m) of the printed discs of a point set (module docstring)."""
    if len(points) < 2:
        return 0.01
    d = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)
    d[np.diag_indices_from(d)] = np.inf
    return float(min(0.01, d.min() / 3.0))


def _points_body(obj: PointSet, paper_margin: float) -> list[str] | None:
    F = _plane(obj.points)
    if F is None:
        return None
    local = (obj.points - F[:3, 3]) @ F[:3, :3]  # the dots in the paper's frame
    r = dot_radius(obj.points)
    half = np.abs(local[:, :2]).max(axis=0) + paper_margin + r
    out = [
        f'<geom name="{obj.name}/paper" type="box" {xml_pose(F)} '
        f'size="{half[0]:.9g} {half[1]:.9g} {PAPER_HALF_THICKNESS}" material="paper"/>'
    ]
    for k, p in enumerate(local):
        pos = F[:3, :3] @ p + F[:3, 3]
        out.append(
            f'<geom name="{obj.name}/dot{k}" type="cylinder" size="{r:.9g} {_DOT_HALF}" '
            f'pos="{_vec(pos)}" xyaxes="{_vec(F[:3, 0])} {_vec(F[:3, 1])}" material="ink"/>'
        )
    return out


def tag_texture(tag: Tag) -> bytes:
    """The PNG of a tag's printed card (module docstring), as MuJoCo's texture file."""
    from redservo.vision.optics import require_cv2
    from redservo.vision.tag_render import tag_bits

    cv2 = require_cv2()
    bits = tag_bits(tag.family, tag.tag_id)  # (N, N), True = black, row 0 at the top
    card = np.full((bits.shape[0] + 2,) * 2, 255, dtype=np.uint8)
    card[1:-1, 1:-1] = np.where(bits, 0, 255)
    img = np.kron(card[::-1, ::-1], np.ones((_TEXELS_PER_CELL,) * 2, dtype=np.uint8))
    ok, png = cv2.imencode(".png", np.ascontiguousarray(img))
    assert ok
    return bytes(png.tobytes())


def _tag_geom(tag: Tag, assets: dict[str, bytes]) -> tuple[str, str]:
    """(asset XML, geom XML) of a tag's card."""
    key = f"tag_{tag.family}_{tag.tag_id}"
    assets[f"{key}.png"] = tag_texture(tag)
    n = tag_bits(tag.family, tag.tag_id).shape[0]
    half = 0.5 * tag.size * (n + 2) / n
    asset = (
        f'<texture name="{key}" type="2d" file="{key}.png"/>'
        f'<material name="{key}" texture="{key}" specular="0.05" shininess="0.1"/>'
    )
    geom = (
        f'<geom name="{tag.name}/card" type="box" size="{half:.9g} {half:.9g} '
        f'{PAPER_HALF_THICKNESS}" material="{key}"/>'
    )
    return asset, geom


def _shape_geom(name: str, kind: str) -> str:
    """The geom of a sphere's or cylinder's fine mesh (:mod:`redservo.physics.meshes`)."""
    return f'<geom name="{name}/{kind}" type="mesh" mesh="{name}/mesh" material="{name}/matte"/>'


def _matte(name: str) -> str:
    """The ``<asset>`` entry of an object's dark matte paint (:data:`SHAPE_RGBA`)."""
    return (
        f'<material name="{name}/matte" rgba="{SHAPE_RGBA}" specular="0" shininess="0" '
        'reflectance="0"/>'
    )


def _object_geoms(
    obj: object, name: str, files: dict[str, bytes], paper_margin: float
) -> tuple[list[str] | None, str]:
    """The geoms of one object in its own frame (None: not drawn) and its ``<asset>`` entries:
    the ``mujoco`` adapter its feature kind declares (:mod:`redservo.features.kinds`)."""
    if isinstance(obj, Tag):
        asset, geom = _tag_geom(obj, files)
        return [geom], asset
    adapter = object_adapter(obj, "mujoco")
    if adapter is None:
        return None, ""
    geoms: tuple[list[str] | None, str] = adapter(obj, name, files, paper_margin)
    return geoms


def points_geoms(
    obj: PointSet, name: str, files: dict[str, bytes], paper_margin: float
) -> tuple[list[str] | None, str]:
    """A point set: its dots on their paper (the point kind's ``mujoco`` adapter)."""
    return _points_body(obj, paper_margin), ""


def sphere_geoms(
    obj: Sphere, name: str, files: dict[str, bytes], paper_margin: float
) -> tuple[list[str], str]:
    """A sphere: a matte mesh (the sphere kind's ``mujoco`` adapter)."""
    mesh = sphere_mesh(f"{name}/mesh", obj.radius, obj.center)
    return [_shape_geom(name, "sphere")], mesh + _matte(name)


def line_geoms(
    obj: Line, name: str, files: dict[str, bytes], paper_margin: float
) -> tuple[list[str], str]:
    """A line: a thin rod along it (the line kind's ``mujoco`` adapter)."""
    a, b = obj.point - obj.direction, obj.point + obj.direction
    mesh = cylinder_mesh(f"{name}/mesh", LINE_ROD_RADIUS, a, b)
    return [_shape_geom(name, "rod")], mesh + _matte(name)


def cylinder_geoms(
    obj: Cylinder, name: str, files: dict[str, bytes], paper_margin: float
) -> tuple[list[str], str]:
    """A cylinder: a matte mesh (the cylinder kind's ``mujoco`` adapter)."""
    a, b = obj.point - obj.axis, obj.point + obj.axis
    mesh = cylinder_mesh(f"{name}/mesh", obj.radius, a, b)
    return [_shape_geom(name, "cylinder")], mesh + _matte(name)


def scene_bodies(
    scene: Scene,
    assets: dict[str, bytes] | None = None,
    *,
    paper_margin: float = 0.05,
    carrier: FloatArray | None = None,
) -> tuple[str, str, list[str], list[str]]:
    """MJCF bodies of the scene's objects, their ``<asset>`` entries, the names drawn and
    the names skipped; texture files go into ``assets`` (name → bytes, for ``from_xml_string``).

    ``carrier`` None: mocap bodies at ``wMo(0)`` (moved by :func:`set_poses`). Else the
    scene's world frame is an end effector ``e`` whose pose at ``qpos = 0``, in the frame of
    the body the XML goes into, is ``carrier`` (4x4): each object is a gravity-compensated
    body fixed at ``carrier · eMo`` there (``eMo = wMo(0)``), carried by the arm's physics."""
    files = {} if assets is None else assets
    asset_xml: list[str] = []
    xml: list[str] = []
    drawn: list[str] = []
    skipped: list[str] = []
    for name in scene.names:
        geoms, asset = _object_geoms(scene.object(name), name, files, paper_margin)
        if geoms is None:
            skipped.append(name)
            continue
        asset_xml.append(asset)
        wMo = scene.wMo(name, 0.0)
        if carrier is None:
            head = f'<body name="obj:{name}" mocap="true" {xml_pose(wMo)}>'
        else:
            head = f'<body name="obj:{name}" gravcomp="1" {xml_pose(carrier @ wMo)}>'
        xml.append(f"{head}{''.join(geoms)}</body>")
        drawn.append(name)
    return "".join(xml), "".join(asset_xml), drawn, skipped


def set_poses(model: Any, data: Any, scene: Scene, names: Sequence[str], t: float) -> None:
    """Move the mocap bodies of ``names`` to their poses ``wMo(t)`` (t in s)."""
    from scipy.spatial.transform import Rotation

    for name in names:
        k = int(model.body_mocapid[model.body(f"obj:{name}").id])
        wMo = scene.wMo(name, t)
        data.mocap_pos[k] = wMo[:3, 3]
        x, y, z, w = Rotation.from_matrix(wMo[:3, :3]).as_quat()
        data.mocap_quat[k] = (w, x, y, z)
