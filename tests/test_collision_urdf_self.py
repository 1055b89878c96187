"""Self-collision pairs of a URDF robot's own ``<collision>`` elements
(redservo.collision.urdf_pairs, redservo.collision.urdf_query): which pairs are checked
(one rigid body, adjacent bodies, an SRDF's ``<disable_collisions>``), their distances and
Jacobians against finite differences, and the scenario keys ``collision.self`` and
``collision.srdf`` with one error for each bad input."""

from __future__ import annotations

import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from redservo.collision import distances
from redservo.collision.urdf_pairs import rigid_bodies, urdf_self_pairs
from redservo.errors import GeometryError, ScenarioError, UnknownNameError
from redservo.robots import shipped_urdf
from tests.test_collision_urdf_distances import _CAPS

pytest.importorskip("coal")
pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio (redservo[urdf])")

_ELEMENTS = {  # the other URDF test's elements, with links 4 and 8 for adjacency and fixed joints
    **_CAPS,
    "panda_link4": '<geometry><sphere radius="0.06"/>',
    "panda_link8": '<origin xyz="0 0 0.05"/><geometry><sphere radius="0.04"/>',
}
_ELEMENTS = {k: _ELEMENTS[k] for k in sorted(_ELEMENTS)}  # file (link) order
_READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


def _urdf(folder: Path, elements: dict[str, str] = _ELEMENTS) -> Path:
    text = shipped_urdf("panda").read_text()
    for link, body in elements.items():
        col = f"<collision>{body}</geometry></collision>"
        text = re.sub(f'(<link name="{link}">)', rf"\1{col}", text)
    path = folder / "panda.urdf"
    path.write_text(text)
    return path


def _srdf(folder: Path, pairs: list[tuple[str, str]]) -> Path:
    rows = "".join(
        f'<disable_collisions link1="{a}" link2="{b}" reason="Never"/>' for a, b in pairs
    )
    path = folder / "panda.srdf"
    path.write_text(f'<?xml version="1.0"?><robot name="panda">{rows}</robot>')
    return path


def _robot(path: Path) -> Any:
    from redservo.robots.urdf import URDFRobot

    return URDFRobot(path, camera_link="panda_link8")


def test_fixed_joints_make_one_body_and_neighbours_are_adjacent(tmp_path: Path) -> None:
    body, adjacent = rigid_bodies(_urdf(tmp_path))
    assert body["panda_link8"] == body["panda_link7"]  # joint8 is fixed
    assert frozenset({"panda_link3", "panda_link4"}) in adjacent
    assert frozenset({body["panda_link6"], body["panda_link8"]}) in adjacent
    pairs = urdf_self_pairs(tmp_path / "panda.urdf", list(_ELEMENTS))
    assert pairs == [
        ("panda_link3", "panda_link5"),
        ("panda_link3", "panda_link7"),
        ("panda_link3", "panda_link8"),
        ("panda_link4", "panda_link7"),
        ("panda_link4", "panda_link8"),
        ("panda_link5", "panda_link7"),
        ("panda_link5", "panda_link8"),
    ]  # not 3-4, 4-5 (adjacent), nor 7-8 (one body)


def test_an_srdf_and_the_exclusions_remove_pairs(tmp_path: Path) -> None:
    urdf = _urdf(tmp_path)
    srdf = _srdf(tmp_path, [("panda_link7", "panda_link3"), ("panda_link5", "panda_link8")])
    pairs = urdf_self_pairs(
        urdf, list(_ELEMENTS), srdf=srdf, exclude=[("panda_link4", "panda_link8")]
    )
    assert ("panda_link3", "panda_link7") not in pairs
    assert ("panda_link5", "panda_link8") not in pairs
    assert ("panda_link4", "panda_link8") not in pairs
    assert len(pairs) == 4


def test_bad_srdf_files_are_one_error_naming_them(tmp_path: Path) -> None:
    urdf = _urdf(tmp_path)
    wrong = _srdf(tmp_path, [("panda_link3", "ur5e_wrist_1_link")])
    with pytest.raises(UnknownNameError, match=r"panda\.srdf.*'ur5e_wrist_1_link'") as err:
        urdf_self_pairs(urdf, list(_ELEMENTS), srdf=wrong)
    assert err.value.argument == "srdf"
    broken = tmp_path / "broken.srdf"
    broken.write_text("<robot><disable_collisions")
    with pytest.raises(GeometryError, match=r"broken\.srdf: cannot read the SRDF"):
        urdf_self_pairs(urdf, list(_ELEMENTS), srdf=broken)
    with pytest.raises(UnknownNameError, match="exclude: unknown link 'hand'"):
        urdf_self_pairs(urdf, list(_ELEMENTS), exclude=[("hand", "panda_link3")])


def test_elements_on_one_body_leave_no_pair_to_check(tmp_path: Path) -> None:
    from redservo.errors import ConfigurationError

    one = {k: v for k, v in _ELEMENTS.items() if k in ("panda_link7", "panda_link8")}
    robot = _robot(_urdf(tmp_path, one))
    with pytest.raises(ConfigurationError, match="no two links") as err:
        distances(robot, _READY, self_collision=True)
    assert err.value.argument == "self"


def test_self_distances_and_their_jacobians(tmp_path: Path) -> None:
    robot = _robot(_urdf(tmp_path))
    q = _READY + 0.1
    recs = distances(robot, q, self_collision=True)
    own = [r for r in recs if r.kind == "self"]
    assert len(own) == 7 and (own[0].first, own[0].second) == ("panda_link3", "panda_link5")
    h = 1e-6

    def d(qq: np.ndarray, k: int) -> float:
        return [r for r in distances(robot, qq, self_collision=True) if r.kind == "self"][
            k
        ].distance

    for k, rec in enumerate(own):
        assert rec.distance > 0.0
        np.testing.assert_allclose(rec.distance, np.linalg.norm(rec.a - rec.b), rtol=1e-9)
        fd = [(d(q + h * e, k) - d(q - h * e, k)) / (2 * h) for e in np.eye(7)]
        np.testing.assert_allclose(rec.jacobian, fd, atol=1e-5)


def _scenario(tmp_path: Path, collision: dict[str, Any]) -> dict[str, Any]:
    text = resources.files("redservo.scenarios").joinpath("panda-urdf-4points.toml").read_text()
    data = tomllib.loads(text)
    data["robot"]["urdf"] = str(tmp_path / "panda.urdf")
    data["collision"] = collision
    return data


def test_scenario_keys_self_and_srdf(tmp_path: Path) -> None:
    from redservo.experiment.build import build
    from redservo.scenario import parse_scenario

    big = dict(_ELEMENTS, panda_link3='<geometry><sphere radius="0.35"/>')
    _urdf(tmp_path, big)  # link 3 overlaps links 5 and 7 at q0
    data = _scenario(tmp_path, {"self": True})
    with pytest.raises(ScenarioError, match="self-collision: links 'panda_link3'") as err:
        build(parse_scenario(data, str(tmp_path / "s.toml"), base_dir=tmp_path))
    assert err.value.argument == "collision.self"
    pairs = [
        (a, b) for a in ("panda_link3",) for b in ("panda_link5", "panda_link7", "panda_link8")
    ]
    _srdf(tmp_path, pairs)
    data = _scenario(tmp_path, {"self": True, "srdf": "panda.srdf"})
    exp = build(parse_scenario(data, str(tmp_path / "s.toml"), base_dir=tmp_path))
    coll = exp.options.collision
    assert coll is not None and coll.srdf == str((tmp_path / "panda.srdf").resolve())
    names = coll.measure(exp.robot, exp.q0, 0.0).names
    assert "panda_link3/panda_link5" not in names and "panda_link4/panda_link7" in names


def test_scenario_srdf_errors_name_the_key(tmp_path: Path) -> None:
    from redservo.experiment.build import build
    from redservo.scenario import parse_scenario

    _urdf(tmp_path)
    data = _scenario(tmp_path, {"self": True, "srdf": "missing.srdf"})
    with pytest.raises(ScenarioError, match=r"key 'collision\.srdf': no such file") as err:
        parse_scenario(data, "s.toml", base_dir=tmp_path)
    assert err.value.argument == "collision.srdf"
    text = resources.files("redservo.scenarios").joinpath("panda-4points.toml").read_text()
    dh = tomllib.loads(text)
    dh["collision"] = {"self": True, "srdf": str(_srdf(tmp_path, []))}
    with pytest.raises(ScenarioError, match="SRDF names the self pairs of a URDF robot") as err:
        build(parse_scenario(dh, "dh.toml"))
    assert err.value.argument == "collision.srdf"


def test_a_run_directory_carries_the_srdf(tmp_path: Path) -> None:
    from redservo.runs.files import bundle_files

    srdf = _srdf(tmp_path, [("panda_link3", "panda_link5")])
    table: dict[str, Any] = {"collision": {"self": True, "srdf": str(srdf)}}
    report = bundle_files(tmp_path / "run", table)
    assert report["copied"] == ["files/panda.srdf"]
    assert table["collision"]["srdf"] == "files/panda.srdf"
    assert (tmp_path / "run" / "files" / "panda.srdf").read_bytes() == srdf.read_bytes()
