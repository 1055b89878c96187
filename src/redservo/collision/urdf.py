"""The ``<collision>`` elements of a URDF file as `coal` geometries, per link.

Primitives (``<box size>`` full extents, ``<cylinder radius length>`` along z, ``<sphere
radius>``) become coal shapes; a ``<mesh filename scale>`` is resolved like the run-files
code resolves meshes (relative to the URDF, ``file://``, or ``package://PKG/...`` in the
folders above it) and must lie, links resolved, inside the robot's own folder (the nearest
folder above the URDF holding a ROS ``package.xml``, else the URDF's folder; the check of
:mod:`redservo.runs.files`): a mesh never makes redservo read outside it. A missing, refused
or unreadable mesh is one :class:`~redservo.errors.GeometryError` naming the file and the
link. Units: metres.

Their distances and Jacobians for a :class:`~redservo.robots.URDFRobot` are
:mod:`redservo.collision.urdf_query`'s (used by :func:`redservo.collision.distances`).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import GeometryError
from redservo.spatial import make_transform, rpy_to_matrix

__all__ = ["UrdfCollision", "urdf_collisions"]


@dataclass(frozen=True, eq=False)
class UrdfCollision:
    """One ``<collision>``: its link, its pose in the link frame ``lMg`` (4x4), its coal
    geometry and what it is (``box``, ``cylinder``, ``sphere`` or the mesh file's path)."""

    link: str
    lMg: FloatArray
    geometry: Any
    source: str


def _floats(text: str | None, n: int, what: str, default: float | None = None) -> FloatArray:
    if text is None and default is not None:
        return np.full(n, default)
    try:
        v = np.array([float(x) for x in (text or "").split()])
    except ValueError:
        v = np.zeros(0)
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise GeometryError(f"{what}: expected {n} finite numbers, got {text!r}")
    return v


def _origin(el: ET.Element | None, what: str) -> FloatArray:
    if el is None:
        return np.eye(4)
    rpy = _floats(el.get("rpy"), 3, f"{what} <origin rpy>", 0.0)
    xyz = _floats(el.get("xyz"), 3, f"{what} <origin xyz>", 0.0)
    return make_transform(rpy_to_matrix(rpy), xyz)


def _mesh(shape: ET.Element, urdf: Path, what: str) -> tuple[Any, str]:
    import coal

    from redservo.runs.files import _find_mesh, _refusal

    name = shape.get("filename", "")
    where = _find_mesh(name, urdf.parent)  # the run files' resolution: one rule for both
    if where is None:
        raise GeometryError(f"{what}: mesh file {name!r} not found (relative to {urdf.parent})")
    found, root = where
    why = _refusal(found, root)
    if why is not None:
        raise GeometryError(f"{what}: mesh file {found} is refused: {why}")
    scale = _floats(shape.get("scale"), 3, f"{what} <mesh scale>", 1.0)
    try:
        return coal.MeshLoader().load(str(found), scale), str(found)
    except Exception as exc:  # coal's loader (assimp) raises several kinds
        raise GeometryError(f"{what}: mesh file {found} cannot be read ({exc})") from None


def _geometry(geo: ET.Element | None, urdf: Path, what: str) -> tuple[Any, str]:
    import coal

    shape = None if geo is None else next(iter(geo), None)
    if shape is None:
        raise GeometryError(f"{what}: <geometry> is empty")
    if shape.tag == "box":
        size = _floats(shape.get("size"), 3, f"{what} <box size>")
        if np.any(size <= 0):
            raise GeometryError(f"{what} <box size>: every extent must be > 0 (m), got {size}")
        return coal.Box(*size), "box"
    if shape.tag in ("cylinder", "sphere"):
        r = float(_floats(shape.get("radius"), 1, f"{what} <{shape.tag} radius>")[0])
        length = 1.0
        if shape.tag == "cylinder":
            length = float(_floats(shape.get("length"), 1, f"{what} <cylinder length>")[0])
        if r <= 0 or length <= 0:
            raise GeometryError(f"{what} <{shape.tag}>: radius and length must be > 0 (m)")
        return (coal.Sphere(r) if shape.tag == "sphere" else coal.Cylinder(r, length)), shape.tag
    if shape.tag == "mesh":
        return _mesh(shape, urdf, what)
    raise GeometryError(f"{what}: unknown geometry <{shape.tag}> (box, cylinder, sphere, mesh)")


def urdf_collisions(path: str | Path) -> list[UrdfCollision]:
    """Every ``<collision>`` of the URDF file ``path``, in file order.

    Raises:
        GeometryError: an unreadable file, a bad primitive, or a mesh that is missing,
            outside the robot's folder or unreadable (names the file and the link).
    """
    urdf = Path(path)
    try:
        root = ET.parse(urdf).getroot()
    except (OSError, ET.ParseError) as exc:
        raise GeometryError(f"{urdf}: cannot read the URDF ({exc})") from None
    out = []
    for link in root.findall("link"):
        name = link.get("name", "")
        for k, col in enumerate(link.findall("collision")):
            what = f"{urdf.name}, link {name!r}, collision {k}"
            geometry, source = _geometry(col.find("geometry"), urdf, what)
            out.append(UrdfCollision(name, _origin(col.find("origin"), what), geometry, source))
    return out
