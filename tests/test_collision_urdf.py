"""URDF ``<collision>`` elements as coal geometries: primitives, meshes inside the robot's
folder, and one error naming the file for a mesh that is missing, outside or unreadable."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from redservo.collision.urdf import urdf_collisions
from redservo.errors import GeometryError

pytest.importorskip("coal")


def _stl(path: Path) -> None:
    """A binary STL tetrahedron of 0.1 m."""
    tris = [
        ((0, 0, 0), (0.1, 0, 0), (0, 0.1, 0)),
        ((0, 0, 0), (0, 0.1, 0), (0, 0, 0.1)),
        ((0, 0, 0), (0, 0, 0.1), (0.1, 0, 0)),
        ((0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1)),
    ]
    data = b"\0" * 80 + struct.pack("<I", len(tris))
    for tri in tris:
        data += struct.pack("<3f", 0, 0, 0)
        for v in tri:
            data += struct.pack("<3f", *v)
        data += b"\0\0"
    path.write_bytes(data)


def _urdf(folder: Path, mesh: str) -> Path:
    path = folder / "arm.urdf"
    path.write_text(f"""<robot name="arm">
  <link name="base">
    <collision><origin xyz="0 0 0.1" rpy="0 0 1.5707963267948966"/>
      <geometry><box size="0.2 0.3 0.4"/></geometry></collision>
    <collision><geometry><cylinder radius="0.05" length="0.3"/></geometry></collision>
  </link>
  <link name="tool">
    <collision><geometry><sphere radius="0.04"/></geometry></collision>
    <collision><geometry><mesh filename="{mesh}" scale="2 2 2"/></geometry></collision>
  </link>
</robot>""")
    return path


def test_primitives_and_a_mesh_inside_the_folder(tmp_path: Path) -> None:
    import coal

    (tmp_path / "meshes").mkdir()
    _stl(tmp_path / "meshes" / "tip.stl")
    cols = urdf_collisions(_urdf(tmp_path, "meshes/tip.stl"))
    assert [(c.link, c.source.rsplit("/", 1)[-1]) for c in cols] == [
        ("base", "box"),
        ("base", "cylinder"),
        ("tool", "sphere"),
        ("tool", "tip.stl"),
    ]
    box = cols[0]
    np.testing.assert_allclose(box.lMg[:3, 3], [0, 0, 0.1])
    np.testing.assert_allclose(box.lMg[:3, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(box.geometry.halfSide, [0.1, 0.15, 0.2])
    # the mesh, scaled by 2, reaches 0.2 m along x: a sphere 0.5 m away is 0.3 m off
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    far = coal.Transform3s(np.eye(3), np.array([0.5, 0.0, 0.0]))
    mesh = cols[3].geometry
    d = coal.distance(mesh, coal.Transform3s(), coal.Sphere(0.0001), far, req, res)
    assert d == pytest.approx(0.3, abs=1e-3)


def test_a_mesh_outside_the_robot_folder_is_refused(tmp_path: Path) -> None:
    robot = tmp_path / "robot"
    robot.mkdir()
    _stl(tmp_path / "secret.stl")
    with pytest.raises(GeometryError, match=r"secret\.stl is refused: it lies outside"):
        urdf_collisions(_urdf(robot, "../secret.stl"))
    with pytest.raises(GeometryError, match=r"link 'tool'.*'/etc/hostname'|hostname is refused"):
        urdf_collisions(_urdf(robot, "/etc/hostname"))


def test_a_missing_or_unreadable_mesh_names_the_file(tmp_path: Path) -> None:
    with pytest.raises(GeometryError, match=r"link 'tool'.*'nothere\.stl' not found"):
        urdf_collisions(_urdf(tmp_path, "nothere.stl"))
    (tmp_path / "broken.stl").write_bytes(b"\0" * 90)
    with pytest.raises(GeometryError, match=r"broken\.stl"):
        urdf_collisions(_urdf(tmp_path, "broken.stl"))


def test_bad_primitives_are_geometry_errors(tmp_path: Path) -> None:
    path = tmp_path / "bad.urdf"
    path.write_text(
        '<robot name="r"><link name="a"><collision><geometry><box size="0.1 0 0.1"/>'
        "</geometry></collision></link></robot>"
    )
    with pytest.raises(GeometryError, match=r"link 'a'.*every extent must be > 0"):
        urdf_collisions(path)
    path.write_text(
        '<robot name="r"><link name="a"><collision><geometry><cone radius="1"/>'
        "</geometry></collision></link></robot>"
    )
    with pytest.raises(GeometryError, match=r"unknown geometry <cone>"):
        urdf_collisions(path)
