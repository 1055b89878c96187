"""A feature kind declared outside the package (examples/custom_feature_segment.py): its
interaction matrix by finite differences, its ``[[features]]`` entry in a scenario (also
when the schema was built before it was declared), its runs with the ideal and the image
sensor, and the errors of a bad declaration."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any, Literal

import numpy as np
import pytest

import redservo
from redservo.errors import ConfigurationError, ScenarioError
from redservo.features import FEATURES, register_feature
from redservo.features.kinds import feature_kinds, forget_feature
from redservo.spatial import exp_twist, inverse, make_transform, rotvec_to_matrix

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "custom_feature_segment.py"


@pytest.fixture(scope="module")
def example() -> Iterator[ModuleType]:
    """The example, imported as a module (it declares the kind ``segment``), forgotten after
    this module's tests (the other tests see the shipped kinds only)."""
    name = "custom_feature_segment"
    spec = importlib.util.spec_from_file_location(name, EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        forget_feature("segment")
        sys.modules.pop(name, None)


def _fd(feat: Any, cMo: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central finite difference of s under camera twists ±h e_j (angles wrapped)."""
    cols = []
    for j in range(6):
        e = np.zeros(6)
        e[j] = h
        sp = feat.value(inverse(exp_twist(e)) @ cMo)
        sm = feat.value(inverse(exp_twist(-e)) @ cMo)
        cols.append(feat.error(sp, sm) / (2 * h))
    return np.column_stack(cols)


@pytest.mark.parametrize("seed", range(5))
def test_segment_interaction_matches_finite_differences(example: ModuleType, seed: int) -> None:
    rng = np.random.default_rng(seed)
    feat = example.SegmentFeature(rng.uniform(-0.2, 0.2, 3), rng.uniform(-0.2, 0.2, 3))
    R = rotvec_to_matrix(rng.uniform(-0.3, 0.3, 3))
    cMo = make_transform(R, np.array([0.1, -0.1, 0.8]) + rng.uniform(-0.1, 0.1, 3))
    m = feat.measure(cMo)
    assert m.s.shape == (4,) and m.inv_depth.shape == (2,)
    np.testing.assert_allclose(feat.interaction(m.s, m.inv_depth), _fd(feat, cMo), atol=1e-6)


def test_the_kind_is_declared_with_its_spec(example: ModuleType) -> None:
    from redservo.schema.features import FEATURE_KINDS

    assert "segment" in feature_kinds() and "segment" not in FEATURES  # shipped ones only
    assert FEATURE_KINDS["segment"] is example.SegmentSpec
    sc = redservo.load_scenario(example.SCENARIO)
    assert [f["kind"] for f in sc.data["features"]] == ["segment", "segment"]


@pytest.mark.parametrize(
    ("entry", "match"),
    [
        ({}, r"features\[0\]\.ends"),
        ({"ends": [0, 7]}, r"features\[0\].*ends must be point indices in \[0, 3\], got \[0, 7\]"),
        ({"ends": [1, 1]}, r"features\[0\].*two distinct finite ends"),
    ],
)
def test_a_bad_segment_entry_is_one_scenario_error(
    example: ModuleType, entry: dict[str, Any], match: str
) -> None:
    table = {**example.SCENARIO, "features": [{"kind": "segment", "object": "target", **entry}]}
    with pytest.raises(ScenarioError, match=match):
        redservo.run(table, max_iterations=1)


@pytest.mark.parametrize("sensor", ["ideal", "image"])
def test_the_example_runs_and_reduces_the_error(example: ModuleType, sensor: str) -> None:
    r = redservo.run(example.SCENARIO, overrides={"sensor.kind": sensor}, max_iterations=8)
    e = np.linalg.norm(r.log.e, axis=1)
    assert r.log.e.shape == (8, 8) and np.isfinite(r.log.q).all()
    assert e[-1] < 0.9 * e[0]


def test_the_image_sensor_measures_the_segment_as_its_truth(example: ModuleType) -> None:
    from redservo.experiment.build import build
    from redservo.vision import ImageSensor

    sc = redservo.load_scenario(example.SCENARIO)
    exp = build(sc)
    bMc = exp.robot.fkine(exp.q0)
    sensor = ImageSensor(exp.camera, depth="estimated")
    reading = sensor.read(exp.task, exp.scene, bMc, 0.0)
    truth, _ = exp.task.measure(exp.scene, bMc, 0.0)
    assert reading.s is not None
    np.testing.assert_allclose(reading.s, truth, atol=2e-3)
    assert all(d.shape == (2,) and (d > 0).all() for d in reading.inv_depth)


def test_a_kind_declared_after_the_schema_is_built_joins_it(example: ModuleType) -> None:
    from redservo.schema import ScenarioSpec  # built: the union is rebuilt on declaration
    from redservo.schema.features import FeatureSpec

    assert ScenarioSpec is not None

    class LateSpec(example.SegmentSpec):  # type: ignore[name-defined]
        kind: Literal["segment_late"]

    globals()["LateSpec"] = LateSpec  # a module attribute, as register_feature wants
    LateSpec.__qualname__ = "LateSpec"

    class LateSegment(example.SegmentFeature):  # type: ignore[name-defined]
        pass

    register_feature("segment_late", LateSegment, schema=LateSpec)
    table = {**example.SCENARIO, "features": [{**example.SCENARIO["features"][0]}]}
    table["features"][0]["kind"] = "segment_late"
    try:
        sc = redservo.load_scenario(table)
        assert sc.data["features"][0]["kind"] == "segment_late"
        assert issubclass(LateSpec, FeatureSpec)
    finally:
        forget_feature("segment_late")
    with pytest.raises(ScenarioError, match="unknown feature kind 'segment_late'"):
        redservo.load_scenario(table)


def test_a_bad_declaration_is_one_configuration_error_and_declares_nothing(
    example: ModuleType,
) -> None:
    with pytest.raises(ConfigurationError, match="must be a subclass of"):
        register_feature("not_a_spec", example.SegmentFeature, schema="redservo.scene:Sphere")
    assert "not_a_spec" not in feature_kinds()
    with pytest.raises(ConfigurationError, match="must be a subclass of"):  # kind literal
        register_feature("segment_b", example.SegmentFeature, schema=example.SegmentSpec)
    assert "segment_b" not in feature_kinds()
    with pytest.raises(ConfigurationError, match=r"unknown adapter role.*measure"):
        register_feature("segment_c", example.SegmentFeature, schema="m:a", measure=len)
    with pytest.raises(ConfigurationError, match="not a module-level"):
        register_feature("segment_d", example.SegmentFeature, schema=lambda: None)  # type: ignore[arg-type]


def test_depth_estimated_uses_the_kinds_adapter(example: ModuleType) -> None:
    from redservo.vision.depth import estimate_inv_depth

    feat = example.SegmentFeature([0, 0, 0], [0.1, 0, 0])
    xy = np.array([[0.0, 0.0], [0.2, 0.0]])  # 0.1 m seen as 0.2: Z = 0.5 m
    d = estimate_inv_depth(feat, np.zeros(4), set_points=feat.points_o, set_xy=xy)
    np.testing.assert_allclose(d, [2.0, 2.0])


def test_forgetting_a_kind_restores_the_shipped_schema(example: ModuleType) -> None:
    from redservo.schema.features import FEATURE_KINDS

    with pytest.raises(ConfigurationError, match="'sphere' is a shipped feature kind"):
        forget_feature("sphere")
    forget_feature("never_declared")  # nothing
    assert tuple(FEATURE_KINDS) == (*FEATURES, "segment")


def test_the_video_draws_the_segment_through_its_adapter(example: ModuleType) -> None:
    from redservo.experiment.build import build
    from redservo.vision.optics import Optics
    from redservo.vision.video import compose_frame

    exp = build(redservo.load_scenario(example.SCENARIO))
    s, _ = exp.task.measure(exp.scene, exp.robot.fkine(exp.q0), 0.0)
    image = np.zeros((exp.camera.height, exp.camera.width), dtype=np.uint8)
    optics = Optics(exp.camera)
    blank = compose_frame(image, optics)
    frame = compose_frame(image, optics, task=exp.task, detected=s)
    changed = np.argwhere((frame != blank).any(axis=2))
    uv = optics.to_pixel(s[:2].reshape(1, 2))[0]  # the first segment's midpoint
    assert np.min(np.linalg.norm(changed[:, ::-1] - uv, axis=1)) < 2.0
