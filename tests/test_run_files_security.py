"""A run directory is made to be shared: a URDF's ``<mesh filename>`` must never copy a file
from outside the robot's own folder, nor a file that is not a mesh, into it
(:mod:`redservo.runs.files`)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from redservo.runs.files import RunFileWarning, bundle_files

_STL = b"solid part\nfacet normal 0 0 1\nendfacet\nendsolid part\n"


def _robot(root: Path, refs: list[str], package: bool = False) -> Path:
    """A user's robot folder ``root/my_robot`` whose URDF (in ``urdf/`` when ``package``)
    names ``refs``; returns the URDF."""
    robot = root / "my_robot"
    (robot / "meshes").mkdir(parents=True)
    (robot / "meshes" / "base.stl").write_bytes(_STL)
    folder = robot / "urdf" if package else robot
    folder.mkdir(exist_ok=True)
    if package:
        (robot / "package.xml").write_text("<package><name>my_robot</name></package>")
    meshes = "".join(f'<visual><geometry><mesh filename="{r}"/></geometry></visual>' for r in refs)
    urdf = folder / "robot.urdf"
    urdf.write_text(f'<robot name="r"><link name="base">{meshes}</link></robot>')
    return urdf


def _copied_files(out: Path) -> set[str]:
    return {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}


@pytest.mark.parametrize(
    "ref",
    [
        "/etc/passwd",
        "file:///etc/hostname",
        # up to / from any tmp_path (pytest-xdist's is one folder deeper: popen-gw0/)
        "../" * 16 + "etc/hostname",
        "package://my_robot/" + "../" * 16 + "etc/passwd",
    ],
)
def test_a_mesh_reference_out_of_the_robot_folder_copies_nothing(tmp_path: Path, ref: str) -> None:
    if not Path("/etc/passwd").is_file() or not Path("/etc/hostname").is_file():
        pytest.skip("needs /etc/passwd and /etc/hostname")
    urdf = _robot(tmp_path / "user", ["meshes/base.stl", ref])
    out = tmp_path / "run"
    with pytest.warns(RunFileWarning, match="outside the robot's folder"):
        report = bundle_files(out, {"robot": {"urdf": str(urdf)}})
    assert _copied_files(out) == {"files/robot.urdf", "files/meshes/base.stl"}
    assert len(report["refused"]) == 1 and ref in report["refused"][0]
    for copy in out.rglob("*"):
        if copy.is_file():
            assert b"root:" not in copy.read_bytes()


def test_a_link_out_of_the_robot_folder_is_refused(tmp_path: Path) -> None:
    secret = tmp_path / "secret.stl"
    secret.write_bytes(_STL)
    urdf = _robot(tmp_path / "user", ["meshes/link.stl"])
    os.symlink(secret, urdf.parent / "meshes" / "link.stl")
    out = tmp_path / "run"
    with pytest.warns(RunFileWarning, match="links resolved"):
        report = bundle_files(out, {"robot": {"urdf": str(urdf)}})
    assert "files/meshes/link.stl" not in _copied_files(out)
    assert report["refused"] and "link.stl" in report["refused"][0]


@pytest.mark.parametrize(
    ("name", "content", "why"),
    [
        ("notes.txt", b"solid\n", "only mesh files"),
        ("id_rsa.stl", b"-----BEGIN OPENSSH PRIVATE KEY-----\nabc\n", "not that of a .stl"),
        ("model.dae", b"password = hunter2\n", "not that of a .dae"),
        ("model.obj", b"password = hunter2\n", "not that of a .obj"),
    ],
)
def test_a_file_that_is_no_mesh_is_refused(
    tmp_path: Path, name: str, content: bytes, why: str
) -> None:
    urdf = _robot(tmp_path / "user", [f"meshes/{name}"])
    (urdf.parent / "meshes" / name).write_bytes(content)
    out = tmp_path / "run"
    with pytest.warns(RunFileWarning, match=why):
        report = bundle_files(out, {"robot": {"urdf": str(urdf)}})
    assert f"files/meshes/{name}" not in _copied_files(out) and len(report["refused"]) == 1


def test_a_description_folder_without_package_xml_is_the_robot_folder(tmp_path: Path) -> None:
    """``myrobot/urdf/robot.urdf`` naming ``../meshes/part.stl`` (no package.xml): copied;
    ``../../elsewhere.stl`` still refused."""
    urdf = _robot(tmp_path / "user", ["../meshes/base.stl", "../../elsewhere.stl"], package=True)
    (urdf.parent.parent / "package.xml").unlink()
    (tmp_path / "user" / "elsewhere.stl").write_bytes(_STL)
    out = tmp_path / "run"
    with pytest.warns(RunFileWarning, match="outside the robot's folder"):
        report = bundle_files(out, {"robot": {"urdf": str(urdf)}})
    assert "files/meshes/base.stl" in _copied_files(out) and len(report["refused"]) == 1


def test_meshes_of_the_robot_package_are_copied(tmp_path: Path) -> None:
    """A ROS package's layout (``PKG/urdf/robot.urdf`` naming ``../meshes`` and
    ``package://PKG/meshes``), and the real formats' headers, are accepted."""
    urdf = _robot(
        tmp_path / "user",
        [
            "../meshes/base.stl",
            "package://my_robot/meshes/arm.dae",
            "package://my_robot/meshes/h.obj",
        ],
        package=True,
    )
    meshes = urdf.parent.parent / "meshes"
    (meshes / "arm.dae").write_bytes(b'<?xml version="1.0"?>\n<COLLADA></COLLADA>\n')
    (meshes / "h.obj").write_bytes(b"# hand\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    binary = meshes / "bin.stl"
    binary.write_bytes(b"\0" * 80 + (1).to_bytes(4, "little") + b"\0" * 50)
    (urdf.parent / "b.urdf").write_text(
        urdf.read_text().replace("../meshes/base.stl", "package://my_robot/meshes/bin.stl")
    )
    for source in (urdf, urdf.parent / "b.urdf"):
        out = tmp_path / f"run-{source.stem}"
        report = bundle_files(out, {"robot": {"urdf": str(source)}})
        assert report["refused"] == [] and report["missing"] == []
        assert len(report["copied"]) == 4


def test_a_mesh_that_cannot_be_found_is_said_not_only_listed(tmp_path: Path) -> None:
    """A referenced file that is not found is not copied; the user is told (a campaign keeps
    no report of the copy, so a list alone would be lost)."""
    urdf = _robot(tmp_path / "user", ["meshes/base.stl", "meshes/gone.stl"])
    out = tmp_path / "run"
    with pytest.warns(RunFileWarning, match=r"1 referenced file\(s\) not found.*gone\.stl"):
        report = bundle_files(out, {"robot": {"urdf": str(urdf)}})
    assert report["missing"] == ["robot.urdf: mesh meshes/gone.stl"]
    assert _copied_files(out) == {"files/robot.urdf", "files/meshes/base.stl"}
