"""Obstacles drawn by the viewer (viser primitives, via a recording stand-in server) and by
``animate``'s 3-D panel (outlines at the obstacle's pose at each frame)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from redservo.collision import Obstacle, Shape
from redservo.runs.load import load_run
from redservo.scenario import load_scenario, parse_scenario
from redservo.scene import ConstantVelocity, Static
from redservo.spatial import make_transform
from redservo.viewer.obstacles import add_obstacles, outline, place_obstacles, posed_outline


class _Scene:
    """Records every ``add_*`` call of viser's scene API and returns a settable handle."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, str, dict[str, Any]]] = []

    def __getattr__(self, method: str) -> Any:
        def add(name: str, *args: Any, **kwargs: Any) -> Any:
            self.calls.append((method, name, kwargs))
            return SimpleNamespace(name=name, position=None, wxyz=None)

        return add


def test_viewer_adds_one_primitive_per_obstacle_and_moves_them() -> None:
    server = SimpleNamespace(scene=_Scene())
    moving = ConstantVelocity(make_transform(t=(0.5, 0, 0.2)), np.array([0, 0.1, 0]), np.zeros(3))
    obstacles = [
        Obstacle("ball", Shape("sphere", radius=0.05), moving),
        Obstacle("crate", Shape("box", size=(0.1, 0.2, 0.3)), Static(make_transform(t=(1, 0, 0)))),
        Obstacle("bar", Shape("capsule", radius=0.03, length=0.4), Static(np.eye(4))),
        Obstacle("post", Shape("cylinder", radius=0.02, length=0.8), Static(np.eye(4))),
        Obstacle("table", Shape("plane"), Static(np.eye(4))),
    ]
    placed = add_obstacles(server, obstacles, 0.0)
    calls = {name: (method, kw) for method, name, kw in server.scene.calls}
    assert calls["/obstacles/ball"] == ("add_icosphere", calls["/obstacles/ball"][1])
    assert calls["/obstacles/ball"][1]["radius"] == 0.05
    assert calls["/obstacles/crate"][0] == "add_box"
    assert calls["/obstacles/crate"][1]["dimensions"] == (0.1, 0.2, 0.3)
    assert {"/obstacles/bar/body", "/obstacles/bar/top", "/obstacles/bar/bottom"} <= set(calls)
    assert calls["/obstacles/post/body"][0] == "add_mesh_simple"
    assert calls["/obstacles/table"][0] == "add_box"
    handles = {h.name: h for h, _, _ in placed}
    np.testing.assert_allclose(handles["/obstacles/crate"].position, [1, 0, 0])
    np.testing.assert_allclose(handles["/obstacles/bar/top"].position, [0, 0, 0.2])
    place_obstacles(placed, 2.0)
    np.testing.assert_allclose(handles["/obstacles/ball"].position, [0.5, 0.2, 0.2])


@pytest.mark.parametrize("kind", ["sphere", "box", "capsule", "cylinder", "plane"])
def test_outlines_lie_on_the_shape(kind: str) -> None:
    shape = {
        "sphere": Shape("sphere", radius=0.1),
        "box": Shape("box", size=(0.2, 0.4, 0.6)),
        "capsule": Shape("capsule", radius=0.1, length=0.4),
        "cylinder": Shape("cylinder", radius=0.1, length=0.4),
        "plane": Shape("plane"),
    }[kind]
    pts = outline(Obstacle("o", shape))
    pts = pts[np.isfinite(pts[:, 0])]
    if kind == "sphere":
        np.testing.assert_allclose(np.linalg.norm(pts, axis=1), 0.1)
    elif kind == "box":
        np.testing.assert_allclose(np.abs(pts).max(axis=0), [0.1, 0.2, 0.3])
    elif kind == "plane":
        np.testing.assert_allclose(pts[:, 2], 0.0)
    else:
        axial = np.clip(pts[:, 2], -0.2, 0.2)
        r = np.linalg.norm(pts - np.stack([0 * axial, 0 * axial, axial], 1), axis=1)
        np.testing.assert_allclose(r, 0.1, atol=1e-12)


def test_animate_panel_draws_the_obstacles(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from redservo.experiment.build import build
    from redservo.viewer.animate import _limits, _Scene3D
    from redservo.viewer.playback import Playback

    sc = load_scenario("panda-4points")
    data = {**sc.data, "simulation": {"max_iterations": 4}}
    data["obstacles"] = [
        {
            "name": "post",
            "shape": "cylinder",
            "radius": 0.02,
            "length": 0.5,
            "pose": {"translation": [0.6, 0.4, 0.25]},
            "motion": {"kind": "constant_velocity", "velocity": [0.0, 0.0, 0.5]},
        },
    ]
    build(parse_scenario(data, sc.source)).run().save(tmp_path / "run")
    pb = Playback(load_run(tmp_path / "run"))
    assert [o.name for o in pb.exp.obstacles] == ["post"]
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    panel = _Scene3D(ax, pb, _limits(pb, [0, 3]))
    fr = pb.frame(3)
    panel.update(fr)
    xs, ys, zs = panel.obstacles[0].get_data_3d()
    expect = posed_outline(pb.exp.obstacles[0], fr.t)
    np.testing.assert_allclose(np.stack([xs, ys, zs], 1), expect)
    assert fr.t > 0 and np.nanmax(zs) == pytest.approx(0.5 + 0.5 * fr.t)
    plt.close(fig)
