"""Copy the files a scenario references into its run directory, so that the run is
self-contained: moved to another folder or machine, ``redservo run DIR/scenario.toml``,
``plot``, ``view`` and ``animate`` need nothing outside it.

:func:`bundle_files` copies, into ``DIR/files/``:

* ``robot.urdf`` when it is a file (a shipped name such as ``"panda"`` stays a name: every
  redservo has it), with every mesh its ``<mesh filename=...>`` elements name that can be
  found (relative to the URDF, ``file://``, absolute, or ``package://PKG/...`` looked up in
  the folders above the URDF and in ``ROS_PACKAGE_PATH``); a mesh outside the URDF's folder
  is copied into ``files/meshes/`` and its reference in the copy rewritten to that relative
  path (the original file is never changed); a mesh that cannot be found is listed, not
  skipped silently. Run directories are made to be shared, so a mesh is copied only when it
  is one (:data:`MESH_SUFFIXES`, its first bytes those of that format, at most
  :data:`MAX_MESH_BYTES`) and lies, links resolved, inside the robot's own folder: the
  nearest folder above the URDF holding a ROS ``package.xml``, else the parent of a URDF
  folder named ``urdf`` (``PKG/urdf/robot.urdf``), else the URDF's folder; or the package a
  ``package://`` reference names. Any other reference (``/etc/passwd``,
  ``../../../etc/hostname``, a link out of the folder) is refused: listed under
  ``"refused"`` with the reason, warned about (:class:`RunFileWarning`), never copied;
* ``robot.file`` of an MJCF robot when it is a file (a shipped name stays a name), with every
  ``file=`` its assets and includes name, in the same layout: MuJoCo only loaded it if they
  all lie inside its folder (:func:`redservo.robots.mjcf_chain.load_model`);
* ``camera.file`` (an intrinsics file) and ``collision.srdf`` (the robot's SRDF);

and rewrites those keys of the resolved scenario table to the copies' paths relative to
the run directory (a scenario's relative paths are read relative to its own file).
"""

from __future__ import annotations

import os
import shutil
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

__all__ = [
    "FILE_KEYS",
    "MAX_MESH_BYTES",
    "MESH_SUFFIXES",
    "RunFileWarning",
    "bundle_files",
    "relocate",
]

FILE_KEYS = (("robot", "urdf"), ("robot", "file"), ("camera", "file"), ("collision", "srdf"))
"""The scenario keys that name a file (table, key)."""

FOLDER = "files"
"""The run directory's folder of copied files."""

MESH_SUFFIXES = (".stl", ".dae", ".obj", ".ply", ".glb", ".gltf")
"""The mesh formats a URDF's ``<mesh filename>`` may name and a run directory may hold."""

MAX_MESH_BYTES = 200 * 1024 * 1024
"""The largest mesh file copied into a run directory (bytes)."""


class RunFileWarning(UserWarning):
    """A file a scenario references was not copied into the run directory (refused)."""


def _looks_like(path: Path) -> bool:
    """Whether the first bytes of ``path`` are those of the mesh format its suffix names (a
    binary STL has no magic: its size must be 84 + 50 per triangle)."""
    suffix = path.suffix.lower()
    with path.open("rb") as f:
        head = f.read(512)
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n").lower()
    if suffix == ".stl":
        size = path.stat().st_size
        count = int.from_bytes(head[80:84], "little") if len(head) >= 84 else -1
        return text.startswith(b"solid") or size == 84 + 50 * count
    if suffix == ".dae":
        return text.startswith(b"<?xml") or text.startswith(b"<collada")
    if suffix == ".ply":
        return head.startswith(b"ply")
    if suffix == ".glb":
        return head.startswith(b"glTF")
    if suffix == ".gltf":
        return text.startswith(b"{")
    # OBJ: text whose first statements are comments or OBJ keywords
    if b"\0" in head:
        return False
    words = (b"#", b"v ", b"vn", b"vt", b"f ", b"o ", b"g ", b"s ", b"mtllib", b"usemtl", b"l ")
    lines = [ln.strip() for ln in head.splitlines()[:-1] if ln.strip()]
    return bool(lines) and all(ln.startswith(words) for ln in lines)


def _robot_root(urdf_dir: Path) -> Path:
    """The robot's own folder: the nearest folder at or above ``urdf_dir`` that holds a ROS
    ``package.xml``; else, for a URDF in a folder named ``urdf`` (a description package's
    ``PKG/urdf/`` naming ``../meshes/...``), that folder's parent; else ``urdf_dir``."""
    for folder in (urdf_dir, *urdf_dir.parents):
        if (folder / "package.xml").is_file():
            return folder
    return urdf_dir.parent if urdf_dir.name == "urdf" else urdf_dir


def _refusal(found: Path, root: Path) -> str | None:
    """Why the mesh file ``found`` may not be copied out of the robot folder ``root``, or
    None when it may (module docstring)."""
    real = found.resolve()
    if not real.is_relative_to(root.resolve()):
        return f"it lies outside the robot's folder {root} (links resolved: {real})"
    if real.suffix.lower() not in MESH_SUFFIXES:
        return f"only mesh files are copied ({', '.join(MESH_SUFFIXES)})"
    size = real.stat().st_size
    if size > MAX_MESH_BYTES:
        return f"it has {size} bytes, more than the {MAX_MESH_BYTES} a mesh may have"
    if not _looks_like(real):
        return f"its content is not that of a {real.suffix.lower()} mesh"
    return None


def _is_shipped_urdf(value: str, section: str = "robot") -> bool:
    """A robot file given by a shipped name (``"panda"``), not a path."""
    plain = "/" not in value and "\\" not in value
    return section == "robot" and plain and not value.endswith((".urdf", ".xml"))


def _mjcf(src: Path, dest: Path, report: dict[str, list[str]]) -> None:
    """Copy an MJCF and the files its elements name (module docstring), same layout."""
    from redservo.robots.mjcf_chain import asset_files

    root = src.resolve().parent
    for found in asset_files(src.resolve(), root):
        target = dest.parent / found.relative_to(root)
        if found.is_file():
            _copy(found, target)
            report["copied"].append(target.relative_to(dest.parent.parent).as_posix())
        else:
            report["missing"].append(f"{src.name}: {found.relative_to(root)}")
    _copy(src, dest)
    report["copied"].append(dest.relative_to(dest.parent.parent).as_posix())


def _free(dest_dir: Path, name: str, taken: set[Path]) -> Path:
    """``dest_dir/name``, or ``dest_dir/STEM-K.SUFFIX`` when that name is already used."""
    candidate, k = dest_dir / name, 1
    stem, suffix = Path(name).stem, Path(name).suffix
    while candidate in taken:
        candidate = dest_dir / f"{stem}-{k}{suffix}"
        k += 1
    taken.add(candidate)
    return candidate


def _copy(src: Path, dst: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    if dst.exists() and dst.samefile(src):  # re-saving a run from its own scenario.toml
        return
    shutil.copyfile(src, dst)


def _find_mesh(ref: str, urdf_dir: Path) -> tuple[Path, Path] | None:
    """The file a URDF ``<mesh filename>`` names and the robot folder it must lie in (the
    package a ``package://`` reference names, else :func:`_robot_root`), or None when it
    cannot be found."""
    if ref.startswith("package://"):
        pkg, _, rest = ref[len("package://") :].partition("/")
        roots = [*urdf_dir.parents, urdf_dir]
        roots += [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        for root in roots:
            for package in (root / pkg, root if root.name == pkg else None):
                if package is not None and (package / rest).is_file():
                    return package / rest, package
        return None
    path = Path(ref[len("file://") :] if ref.startswith("file://") else ref)
    path = path if path.is_absolute() else urdf_dir / path
    return (path, _robot_root(urdf_dir)) if path.is_file() else None


def _urdf(src: Path, dest: Path, taken: set[Path], report: dict[str, list[str]]) -> None:
    """Copy a URDF and its meshes (module docstring)."""
    text = src.read_text(encoding="utf-8")
    try:
        refs = {str(m.get("filename")) for m in ET.fromstring(text).iter("mesh")}
    except ET.ParseError:  # the run built it, so this is unexpected: copy it as it is
        refs = set()
    refs.discard("None")
    for ref in sorted(refs):
        where = _find_mesh(ref, src.parent)
        if where is None:
            report["missing"].append(f"{src.name}: mesh {ref}")
            continue
        found, root = where
        why = _refusal(found, root)
        if why is not None:
            report["refused"].append(f"{src.name}: mesh {ref}: {why}")
            warnings.warn(
                f"{src}: <mesh filename={ref!r}> not copied into the run directory: {why}",
                RunFileWarning,
                stacklevel=2,
            )
            continue
        try:
            rel = found.resolve().relative_to(src.parent.resolve())
        except ValueError:
            rel = None
        if rel is not None and not ref.startswith(("package://", "file://", "/")):
            target = dest.parent / rel  # same layout: the reference stays as it is
        else:
            target = _free(dest.parent / "meshes", found.name, taken)
            new = target.relative_to(dest.parent).as_posix()
            for quote in ('"', "'"):
                text = text.replace(
                    f"filename={quote}{ref}{quote}", f"filename={quote}{new}{quote}"
                )
        _copy(found, target)
        report["copied"].append(target.relative_to(dest.parent.parent).as_posix())
    dest.parent.mkdir(parents=True, exist_ok=True)
    if not (dest.exists() and dest.samefile(src)):
        dest.write_text(text, encoding="utf-8")
    report["copied"].append(dest.relative_to(dest.parent.parent).as_posix())


def bundle_files(out: Path, table: dict[str, Any]) -> dict[str, list[str]]:
    """Copy the files ``table`` (a resolved scenario, absolute paths) references into
    ``out/files/`` and point its keys at the copies (module docstring).

    Returns:
        ``{"copied": [...], "missing": [...], "refused": [...]}``: the files written
        (relative to ``out``), the references that could not be found (e.g. a mesh) and the
        meshes refused, with the reason (module docstring).
    """
    report: dict[str, list[str]] = {"copied": [], "missing": [], "refused": []}
    taken: set[Path] = set()
    for section, key in FILE_KEYS:
        sub = table.get(section)
        value = sub.get(key) if isinstance(sub, dict) else None
        if not isinstance(value, str) or _is_shipped_urdf(value, section):
            continue
        src = Path(value)
        if not src.is_file():
            report["missing"].append(f"{section}.{key}: {value}")
            continue
        dest = _free(out / FOLDER, src.name, taken)
        if key == "urdf":
            _urdf(src, dest, taken, report)
        elif section == "robot":
            _mjcf(src, dest, report)
        else:
            _copy(src, dest)
            report["copied"].append(dest.relative_to(out).as_posix())
        assert isinstance(sub, dict)
        sub[key] = dest.relative_to(out).as_posix()
    if report["missing"]:  # said, not only listed: a campaign keeps no report
        warnings.warn(
            f"{len(report['missing'])} referenced file(s) not found, so not copied into "
            f"{out / FOLDER} (a replay of the moved directory will not have them): "
            + "; ".join(report["missing"]),
            RunFileWarning,
            stacklevel=2,
        )
    return report


def relocate(table: dict[str, Any], root: Path) -> None:
    """Point the file keys of ``table`` whose file is gone at the copy in ``root/files/``
    (a moved campaign directory: ``definition.json`` names the original files), when there
    is one; the others are left as they are (building then names the missing file)."""
    for section, key in FILE_KEYS:
        sub = table.get(section)
        value = sub.get(key) if isinstance(sub, dict) else None
        if not isinstance(value, str) or _is_shipped_urdf(value, section):
            continue
        path = Path(value)
        if not path.is_absolute():
            path = root / path
        copy = root / FOLDER / Path(value).name
        if not path.is_file() and copy.is_file():
            assert isinstance(sub, dict)
            sub[key] = str(copy.resolve())
