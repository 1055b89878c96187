"""The viewer reads the mesh formats URDFs ship (COLLADA, STL, OBJ) through trimesh and
pycollada (the ``viewer`` extra); animate's 3-D panel joins only the links that carry the
camera; a servo-loop run without its scenario says exactly why it cannot be viewed."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from redservo.errors import ConfigurationError
from redservo.viewer.animate import arm_chain
from redservo.viewer.meshes import urdf_visuals

ROOT = Path(__file__).resolve().parents[1]

_DAE = """<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
 <asset><unit meter="1" name="meter"/><up_axis>Z_UP</up_axis></asset>
 <library_geometries><geometry id="g"><mesh>
  <source id="p"><float_array id="pa" count="12">0 0 0 0.1 0 0 0 0.1 0 0 0 0.1</float_array>
   <technique_common><accessor source="#pa" count="4" stride="3">
    <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
   </accessor></technique_common></source>
  <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
  <triangles count="4"><input semantic="VERTEX" source="#v" offset="0"/>
   <p>0 2 1 0 1 3 0 3 2 1 2 3</p></triangles>
 </mesh></geometry></library_geometries>
 <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node>
 </visual_scene></library_visual_scenes>
 <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"""

_OBJ = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def _urdf(tmp_path: Path) -> Path:
    import trimesh

    (tmp_path / "tet.dae").write_text(_DAE)
    (tmp_path / "tet.obj").write_text(_OBJ)
    trimesh.load(str(tmp_path / "tet.obj"), force="mesh").export(str(tmp_path / "tet.stl"))
    links = "".join(
        f'<link name="{name}"><visual><geometry><mesh filename="tet.{ext}"/></geometry>'
        "</visual></link>"
        for name, ext in (("a", "dae"), ("b", "stl"), ("c", "obj"))
    )
    path = tmp_path / "r.urdf"
    path.write_text(f'<robot name="r">{links}</robot>')
    return path


def test_collada_stl_and_obj_meshes_are_read(tmp_path: Path) -> None:
    pytest.importorskip("trimesh")
    pytest.importorskip("collada")
    got = urdf_visuals(_urdf(tmp_path))
    assert got.notes == []
    assert [v.link for v in got.visuals] == ["a", "b", "c"]
    for v in got.visuals:
        assert v.vertices.shape == (4, 3) and v.faces.shape == (4, 3)
        assert np.isclose(float(np.abs(v.vertices).max()), 0.1)


def test_the_viewer_extra_installs_the_collada_reader() -> None:
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    viewer = extras["viewer"]
    assert any(d.startswith("trimesh>=") for d in viewer)
    assert any(d.startswith("pycollada>=") for d in viewer)


def test_animate_joins_only_the_links_that_carry_the_camera() -> None:
    poses = {n: np.eye(4) for n in ("base", "wheel_l", "caster", "arm1", "antenna", "cam")}
    for i, n in enumerate(poses):
        poses[n][0, 3] = i
    mobile = SimpleNamespace(chain_links=("base", "arm1", "cam"))
    assert [T[0, 3] for T in arm_chain(mobile, poses)] == [0, 3, 5]
    assert len(arm_chain(SimpleNamespace(), poses)) == 6  # DH / Afma6: already a chain


def test_urdf_robot_knows_its_camera_chain(tmp_path: Path) -> None:
    pytest.importorskip("pinocchio")
    from redservo.robots import URDFRobot

    joint = (
        '<joint name="{n}" type="{t}"><parent link="{p}"/><child link="{c}"/>'
        '<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
    )
    names = ("base", "wheel", "caster", "arm1", "arm2", "antenna", "cam")
    joints = [
        ("w", "continuous", "base", "wheel"),
        ("k", "fixed", "base", "caster"),
        ("j1", "revolute", "base", "arm1"),
        ("j2", "revolute", "arm1", "arm2"),
        ("an", "fixed", "arm1", "antenna"),
        ("jc", "fixed", "arm2", "cam"),
    ]
    links = "".join(f'<link name="{n}"/>' for n in names)
    body = "".join(joint.format(n=n, t=t, p=p, c=c) for n, t, p, c in joints)
    path = tmp_path / "mobile.urdf"
    path.write_text(f'<robot name="mobile">{links}{body}</robot>')
    robot = URDFRobot(path, camera_link="cam")
    assert robot.chain_links == ("base", "arm1", "arm2", "cam")
    poses = robot.link_poses(np.zeros(2))
    assert len(arm_chain(robot, poses)) == 4 < len(poses)


def test_a_servo_run_without_its_scenario_says_why(tmp_path: Path) -> None:
    from redservo.runs.load import load_run

    (tmp_path / "summary.json").write_text(
        json.dumps({"outcome": "converged", "max_cycle_time": 0.001})
    )
    np.savez(tmp_path / "log.npz", t=np.zeros(2))
    with pytest.raises(ConfigurationError, match=r"servo-loop run .* scenario\.toml to view it"):
        load_run(tmp_path).scenario
