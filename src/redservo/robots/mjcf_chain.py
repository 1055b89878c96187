"""An MJCF file read by MuJoCo, and its serial chain as fixed transforms and joint axes.

:func:`load_model` checks the file's assets (every ``file=`` of ``<mesh>``, ``<texture>``,
``<hfield>``, ``<skin>`` and ``<include>`` must lie, links resolved, inside the MJCF's folder:
a model never makes redservo read outside it) and loads it with ``mujoco.MjModel``.
:func:`compile_mjcf_chain` turns the bodies from ``base`` down to ``tip`` into the form of
:class:`~redservo.robots.chain.ChainRobot`.

MuJoCo's kinematics (``mj_kinematics``): a body's frame is its parent's times the fixed
``(body_pos, body_quat)``, then, for each of its joints in order, ``T(p) M(a, q − ref) T(−p)``
with ``p = jnt_pos`` and ``a = jnt_axis`` in the body frame: a rotation of ``q − ref`` rad
about the axis through ``p`` (hinge) or a translation of ``q − ref`` m along it (slide);
``ref`` is the joint's ``qpos0``. A chain joint becomes ``F_i = (fixed so far) T(p) M(a, −ref)``
then ``M(a, q_i)`` (the two motions share their axis, so they commute), and ``T(−p)`` starts
the next fixed transform; a locked joint is folded in at its value. ``q`` is MuJoCo's
``qpos`` of the servoed joints. Units: metres, radians.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Final

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, GeometryError, UnknownNameError
from redservo.spatial import make_transform, rotvec_to_matrix

__all__ = [
    "FLIP",
    "asset_files",
    "chain_path",
    "compile_mjcf_chain",
    "load_model",
    "names_of",
    "pose_of",
    "tip_frame",
]

_ASSET_DIRS = {
    "mesh": "meshdir",
    "skin": "meshdir",
    "hfield": "texturedir",
    "texture": "texturedir",
}


def _mujoco() -> Any:
    # MuJoCo reads MUJOCO_GL once, at its first import: the default of redservo.physics
    # (egl, offscreen) must be in place before a MJCF robot imports it first, or a later
    # MuJoCo simulator or camera of the same process cannot render (physics/_mj.py)
    os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - mujoco is a dependency of the extra
        raise ConfigurationError(
            "MJCFRobot needs MuJoCo: pip install 'redservo[mujoco]'", argument="path"
        ) from exc
    return mujoco


def asset_files(
    xml: Path, root: Path, seen: set[Path] | None = None, dirs: Mapping[str, str] | None = None
) -> list[Path]:
    """Every file (resolved) that the ``file*=`` attributes of ``xml``'s elements and of its
    includes name (an include inherits the ``<compiler>`` folders of the file including it).

    Raises:
        ConfigurationError: ``xml`` (or an include) is not well-formed XML.
        GeometryError: a file that resolves outside ``root`` (module docstring).
    """
    seen = set() if seen is None else seen
    if xml in seen:
        return []
    seen.add(xml)
    try:
        tree = ET.parse(xml).getroot()
    except (OSError, ET.ParseError) as exc:
        raise ConfigurationError(f"{xml}: cannot read the MJCF ({exc})", argument="path") from None
    compiler = tree.find("compiler")
    dirs = {**(dirs or {}), **({} if compiler is None else compiler.attrib)}
    out = []
    for el in tree.iter():
        # file=, and a cube texture's fileright= ... fileback=
        for attr, name in ((a, v) for a, v in el.attrib.items() if a.startswith("file")):
            sub = dirs.get(_ASSET_DIRS.get(el.tag, ""), dirs.get("assetdir", ""))
            found = ((root / name) if el.tag == "include" else (root / sub / name)).resolve()
            if not found.is_relative_to(root):
                raise GeometryError(
                    f"{xml}: <{el.tag} {attr}={name!r}> resolves to {found}, outside the "
                    f"model's folder {root}; a model may only read files inside its folder",
                    argument="path",
                )
            out.append(found)
            if el.tag == "include" and found.is_file():
                out += asset_files(found, root, seen, dirs)
    return out


def load_model(path: str | os.PathLike[str]) -> Any:
    """The ``mujoco.MjModel`` of the MJCF file ``path`` (assets checked first).

    Raises:
        ConfigurationError: the file is missing or MuJoCo rejects it (MuJoCo's message).
        GeometryError: an asset outside the model's folder (names the file).
    """
    mujoco = _mujoco()
    file = Path(path)
    if not file.is_file():
        raise ConfigurationError(f"MJCF file {str(file)!r} does not exist", argument="path")
    asset_files(file.resolve(), file.resolve().parent)
    try:
        return mujoco.MjModel.from_xml_path(str(file))
    except ValueError as exc:  # MuJoCo's parse and compile errors
        said = " ".join(str(exc).split())
        raise ConfigurationError(f"MuJoCo cannot load {file}: {said}", argument="path") from None


def names_of(model: Any, kind: str) -> list[str]:
    """The names of every ``"body"``, ``"site"`` or ``"joint"`` of the model, in id order."""
    count = {"body": model.nbody, "site": model.nsite, "joint": model.njnt}[kind]
    get = getattr(model, kind)
    return [get(i).name for i in range(count)]


def pose_of(pos: FloatArray, quat: FloatArray) -> FloatArray:
    """The 4x4 pose of MuJoCo's ``pos`` (m) and unit ``quat`` (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat)
    R = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return make_transform(R, np.asarray(pos, dtype=float))


FLIP: Final = np.diag([1.0, -1.0, -1.0, 1.0])
"""A MuJoCo ``<camera>`` frame (looking along −z, y up) to ours (along +z, y down): π about x."""


def tip_frame(model: Any, tip: str, source: str) -> tuple[int, FloatArray]:
    """``(body id, pose of the tip in that body)``: ``tip`` names a site, else a ``<camera>``
    (then turned by π about x, :data:`FLIP`: our camera frame), else a body."""
    sites, bodies = names_of(model, "site"), names_of(model, "body")
    cameras = [model.camera(i).name for i in range(model.ncam)]
    if tip in sites:
        k = sites.index(tip)
        return int(model.site_bodyid[k]), pose_of(model.site_pos[k], model.site_quat[k])
    if tip in cameras:
        k = cameras.index(tip)
        return int(model.cam_bodyid[k]), pose_of(model.cam_pos[k], model.cam_quat[k]) @ FLIP
    if tip in bodies:
        return bodies.index(tip), np.eye(4)
    raise UnknownNameError(
        f"tip: {tip!r} is neither a site, a camera nor a body of {source}; sites: "
        f"{', '.join(sites) or '(none)'}; cameras: {', '.join(cameras) or '(none)'}; "
        f"bodies: {', '.join(bodies[1:])}",
        argument="tip",
    )


def chain_path(model: Any, base: int, tip_body: int, source: str) -> list[int]:
    """The body ids from below ``base`` down to ``tip_body``, in order (base excluded)."""
    path, b = [], tip_body
    while b != base:
        if b == 0:
            names = names_of(model, "body")
            raise ConfigurationError(
                f"tip: body {names[tip_body]!r} is not below base {names[base]!r} in {source}",
                argument="tip",
            )
        path.append(b)
        b = int(model.body_parentid[b])
    return path[::-1]


def _motion(axis: FloatArray, value: float, slide: bool) -> FloatArray:
    if slide:
        return make_transform(np.eye(3), axis * value)
    return make_transform(rotvec_to_matrix(axis * value), np.zeros(3))


def compile_mjcf_chain(
    model: Any,
    path: Sequence[int],
    servo: Sequence[int],
    locked: Mapping[int, float],
    end: FloatArray,
) -> tuple[list[FloatArray], FloatArray, list[str]]:
    """``(origins, axes, joint types)`` of the chain through the bodies ``path``.

    Args:
        model: The MjModel.
        path: Body ids, base excluded, down to the tip's body.
        servo: The servoed joint ids (in chain order).
        locked: Value (m or rad) of every other joint of the path, by joint id.
        end: The tip's pose in the last body (4x4); folded into the last transform.

    Returns:
        ``origins`` (n + 1 4x4 transforms: the last is ``F_end``), ``axes`` (n, 3) and the
        joint types, as :class:`~redservo.robots.chain.ChainRobot` takes them.
    """
    acc = np.eye(4)
    origins, axes, types = [], [], []
    for b in path:
        acc = acc @ pose_of(model.body_pos[b], model.body_quat[b])
        first = int(model.body_jntadr[b])
        for j in range(first, first + int(model.body_jntnum[b])):
            p = np.asarray(model.jnt_pos[j], dtype=float)
            a = np.asarray(model.jnt_axis[j], dtype=float)
            slide = int(model.jnt_type[j]) == 2  # mjJNT_SLIDE
            ref = float(model.qpos0[model.jnt_qposadr[j]])
            acc = acc @ make_transform(np.eye(3), p)
            if j in servo:
                origins.append(acc @ _motion(a, -ref, slide))
                axes.append(a)
                types.append("prismatic" if slide else "revolute")
                acc = np.eye(4)
            else:
                acc = acc @ _motion(a, locked[j] - ref, slide)
            acc = acc @ make_transform(np.eye(3), -p)
    origins.append(acc @ end)
    return origins, np.array(axes).reshape(-1, 3), types
