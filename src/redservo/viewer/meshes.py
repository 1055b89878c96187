"""What the viewer draws as surfaces: a URDF robot's visual geometry, and the target objects.

:func:`urdf_visuals` reads the ``<visual>`` elements of a URDF file (as viser's and mink's
users see a robot): each one's link, its pose in the link frame (``<origin xyz rpy>``,
m and rad, ``R = Rz(yaw) Ry(pitch) Rx(roll)``), its colour (``<material><color rgba>``,
inline or by name) and its triangles:

* ``<mesh filename scale>``: STL, OBJ, DAE, ... loaded with trimesh (``redservo[viewer]``);
  ``package://pkg/…`` is looked up in the ancestors of the URDF's folder named ``pkg``, then
  next to the file; relative paths are relative to the URDF's folder;
* ``<box size>``, ``<cylinder radius length>`` (along z, centred) and ``<sphere radius>``:
  built here, no library needed.

A mesh file that is missing, or that trimesh cannot read (or trimesh itself), is left out
with a note (:attr:`Visuals.notes`); the viewer then still draws the links as sticks, which
it always does. Shapes for the target objects: :func:`cylinder_mesh`, :func:`tag_meshes`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray

__all__ = [
    "Visual",
    "Visuals",
    "box_mesh",
    "cylinder_mesh",
    "sphere_mesh",
    "tag_meshes",
    "urdf_visuals",
]

Mesh = tuple[NDArray[np.float32], NDArray[np.int32]]
"""Vertices (V, 3) in metres and triangles (F, 3), indices into the vertices."""


@dataclass(frozen=True)
class Visual:
    """One ``<visual>`` of a link.

    Attributes:
        link: The link's name.
        lMv: Pose (4x4, m) of the geometry in the link frame.
        vertices: (V, 3) float32, m, in the geometry's frame (the file's ``scale`` applied).
        faces: (F, 3) int32 triangles.
        color: RGB 0-255 of its material, or None when the file gives none.
        source: What it was made from (``"box"``, ``"cylinder"``, ``"sphere"``, a file path).
    """

    link: str
    lMv: FloatArray
    vertices: NDArray[np.float32]
    faces: NDArray[np.int32]
    color: tuple[int, int, int] | None
    source: str


@dataclass(frozen=True)
class Visuals:
    """The visual geometry of a URDF file, and what could not be drawn."""

    visuals: list[Visual] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def _floats(text: str | None, n: int, default: float = 0.0) -> FloatArray:
    vals = [float(v) for v in (text or "").split()]
    if len(vals) == 1 and n > 1:
        vals = vals * n
    return np.array(vals if len(vals) == n else [default] * n, dtype=float)


def _origin(elem: ET.Element | None) -> FloatArray:
    T = np.eye(4)
    if elem is None:
        return T
    x, y, z = _floats(elem.get("xyz"), 3)
    r, p, w = _floats(elem.get("rpy"), 3)
    cr, sr, cp, sp, cw, sw = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(w), np.sin(w)
    Rz = np.array([[cw, -sw, 0.0], [sw, cw, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    T[:3, :3] = Rz @ Ry @ Rx
    T[:3, 3] = (x, y, z)
    return T


def _rgb(elem: ET.Element | None, named: dict[str, tuple[int, int, int]]) -> tuple[int, ...] | None:
    if elem is None:
        return None
    color = elem.find("color")
    if color is not None and color.get("rgba"):
        rgba = np.clip(_floats(color.get("rgba"), 4, 1.0), 0.0, 1.0)
        return tuple(int(np.rint(255.0 * c)) for c in rgba[:3])
    return named.get(elem.get("name", ""))


def box_mesh(size: FloatArray) -> Mesh:
    """A box of sides ``size`` (3,) m, centred at the origin, axis-aligned."""
    h = 0.5 * np.asarray(size, dtype=float)
    v = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    f = [
        [0, 1, 3],
        [0, 3, 2],
        [4, 6, 7],
        [4, 7, 5],
        [0, 4, 5],
        [0, 5, 1],
        [2, 3, 7],
        [2, 7, 6],
        [0, 2, 6],
        [0, 6, 4],
        [1, 5, 7],
        [1, 7, 3],
    ]
    return v.astype(np.float32), np.array(f, dtype=np.int32)


def cylinder_mesh(radius: float, length: float, n: int = 24) -> Mesh:
    """A closed cylinder of ``radius`` and ``length`` (m) along z, centred at the origin."""
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    ring = np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1)
    lo = np.hstack([ring, np.full((n, 1), -0.5 * length)])
    hi = np.hstack([ring, np.full((n, 1), 0.5 * length)])
    v = np.vstack([lo, hi, [[0.0, 0.0, -0.5 * length], [0.0, 0.0, 0.5 * length]]])
    i = np.arange(n)
    j = (i + 1) % n
    side = np.concatenate([np.stack([i, j, n + j], 1), np.stack([i, n + j, n + i], 1)])
    caps = np.concatenate(
        [np.stack([np.full(n, 2 * n), j, i], 1), np.stack([np.full(n, 2 * n + 1), n + i, n + j], 1)]
    )
    return v.astype(np.float32), np.concatenate([side, caps]).astype(np.int32)


def sphere_mesh(radius: float, n: int = 16) -> Mesh:
    """A UV sphere of ``radius`` (m) at the origin."""
    th = np.linspace(0.0, np.pi, n + 1)
    ph = np.linspace(0.0, 2.0 * np.pi, 2 * n, endpoint=False)
    t, p = np.meshgrid(th, ph, indexing="ij")
    v = radius * np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    m = 2 * n
    faces = []
    for r in range(n):
        for c in range(m):
            a, b = r * m + c, r * m + (c + 1) % m
            faces += [[a, a + m, b + m], [a, b + m, b]]
    return v.reshape(-1, 3).astype(np.float32), np.array(faces, dtype=np.int32)


def tag_meshes(size: float, cells: int = 8) -> tuple[Mesh, Mesh]:
    """A fiducial tag lying in its ``z = 0`` plane: the white square (one cell of margin
    around the black border, ``size * (cells + 2) / cells`` m wide) just behind the black
    square of side ``size`` (m), both seen from ``+z`` and ``-z``."""

    def square(half: float, z: float) -> Mesh:
        v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]])
        f = np.array([[0, 1, 2], [0, 2, 3], [0, 2, 1], [0, 3, 2]])  # both faces
        return v.astype(np.float32), f.astype(np.int32)

    margin = 0.5 * size * (cells + 2) / cells
    return square(margin, -1e-4 * size), square(0.5 * size, 1e-4 * size)


def _package_candidates(name: str, base: Path) -> list[Path]:
    if name.startswith("file://"):
        name = name[len("file://") :]
    if not name.startswith("package://"):
        p = Path(name)
        return [p if p.is_absolute() else base / p]
    rest = name[len("package://") :]
    pkg, _, sub = rest.partition("/")
    roots = [d for d in (base, *base.parents) if d.name == pkg]
    return [r / sub for r in roots] + [base / sub, base.parent / sub, base / rest]


def _load_mesh(path: Path, scale: FloatArray) -> Mesh:
    import trimesh

    mesh: Any = trimesh.load(str(path), force="mesh")
    v = np.asarray(mesh.vertices, dtype=np.float64) * scale
    f = np.asarray(mesh.faces, dtype=np.int64)
    if v.ndim != 2 or f.ndim != 2 or not len(f):
        raise ValueError("no triangles")
    return v.astype(np.float32), f.astype(np.int32)


def _geometry(geo: ET.Element, base: Path) -> tuple[Mesh, str]:
    """The triangles of a ``<geometry>``; raises LookupError (missing file) or ValueError."""
    shape = next(iter(geo), None)
    if shape is None:
        raise ValueError("empty <geometry>")
    if shape.tag == "box":
        return box_mesh(_floats(shape.get("size"), 3)), "box"
    if shape.tag == "cylinder":
        r, length = float(shape.get("radius", 0)), float(shape.get("length", 0))
        return cylinder_mesh(r, length), "cylinder"
    if shape.tag == "sphere":
        return sphere_mesh(float(shape.get("radius", 0))), "sphere"
    if shape.tag != "mesh":
        raise ValueError(f"unknown geometry <{shape.tag}>")
    name = shape.get("filename", "")
    found = next((p for p in _package_candidates(name, base) if p.is_file()), None)
    if found is None:
        raise LookupError(name)
    try:
        import trimesh  # noqa: F401
    except ImportError:
        raise ValueError("trimesh is not installed: pip install 'redservo[viewer]'") from None
    try:
        return _load_mesh(found, _floats(shape.get("scale"), 3, 1.0)), str(found)
    except Exception as exc:  # trimesh raises many kinds: one note per file
        raise ValueError(f"{found}: trimesh could not read it ({exc})") from None


def urdf_visuals(path: str | Path, links: set[str] | None = None) -> Visuals:
    """The visuals of the URDF file ``path`` (of the ``links`` given, default all).

    Never raises for a visual it cannot draw: that one is left out with a note. A file that
    is not readable XML gives no visuals and one note.
    """
    path = Path(path)
    out = Visuals()
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        out.notes.append(f"{path}: cannot read the visuals ({exc})")
        return out
    named = {
        m.get("name", ""): c
        for m in root.findall("material")
        if (c := _rgb(m, {})) is not None and len(c) == 3
    }
    missing = []
    for link in root.findall("link"):
        name = link.get("name", "")
        if links is not None and name not in links:
            continue
        for vis in link.findall("visual"):
            geo = vis.find("geometry")
            if geo is None:
                continue
            try:
                (v, f), source = _geometry(geo, path.parent)
            except LookupError as exc:
                missing.append(str(exc.args[0]))
                continue
            except ValueError as exc:
                out.notes.append(f"{path.name}, link {name}: {exc}")
                continue
            color = _rgb(vis.find("material"), named)
            rgb = (int(color[0]), int(color[1]), int(color[2])) if color else None
            out.visuals.append(Visual(name, _origin(vis.find("origin")), v, f, rgb, source))
    if missing:
        out.notes.append(
            f"{path.name}: {len(missing)} mesh file(s) not found (e.g. {missing[0]}); "
            "those links are drawn as sticks"
        )
    return out
