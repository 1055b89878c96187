"""One declaration per feature kind (redservo.features.kinds): the class, the scenario entry
and the adapters of the observed scene object are declared beside the feature class, and the
dispatching sites (image renderer, MuJoCo scene, 3-D viewer, schema, make_feature) look them
up instead of testing types."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import pytest

from redservo.errors import ConfigurationError, UnknownNameError
from redservo.features import FEATURES, SphereFeature, feature_class, make_feature
from redservo.features.kinds import (
    SHIPPED,
    FeatureKind,
    feature_kinds,
    forget_feature,
    object_adapter,
)
from redservo.scene import Cylinder, Line, PointSet, Sphere, Tag
from redservo.schema.features import SphereSpec


class _RingSpec(SphereSpec):
    kind: Literal["ring"]  # type: ignore[assignment]


def test_the_shipped_kinds_are_declared_beside_their_classes_in_one_order() -> None:
    from redservo.schema.features import FEATURE_KINDS

    kinds = feature_kinds()
    assert tuple(kinds) == SHIPPED == FEATURES == tuple(FEATURE_KINDS)
    for name, kind in kinds.items():
        assert feature_class(name) is kind.feature
        assert FEATURE_KINDS[name].model_fields["kind"].annotation.__args__ == (name,)  # type: ignore[union-attr]
    assert kinds["sphere"].feature.__module__ == "redservo.features.sphere"
    with pytest.raises(UnknownNameError, match="allowed: point, line, cylinder, sphere"):
        feature_class("blob")


def test_every_scene_object_finds_its_adapters_by_its_class() -> None:
    from redservo.physics import scenes
    from redservo.viewer import playback
    from redservo.vision import shapes

    sphere = Sphere("s", radius=0.1)
    assert object_adapter(sphere, "mujoco") is scenes.sphere_geoms
    assert object_adapter(sphere, "viewer") is playback.sphere_primitive
    assert object_adapter(sphere, "render") is shapes._sphere_layer
    assert object_adapter(PointSet("p", np.zeros((1, 3))), "viewer") is playback.points_primitive
    assert (
        object_adapter(Line("l", np.zeros(3), np.array([1.0, 0, 0])), "mujoco") is scenes.line_geoms
    )
    assert object_adapter(Cylinder("c", 0.05, np.array([0, 0, 1.0])), "render") is (
        shapes._cylinder_layer
    )
    # a tag is a point set: the viewer draws its corners; the renderer and MuJoCo keep
    # their own tag branch before the lookup
    tag = Tag("t", size=0.1)
    assert object_adapter(tag, "viewer") is playback.points_primitive
    assert object_adapter(object(), "render") is None


class _Ring(Sphere):
    """A made-up object kind: a sphere seen as a ring (for the registry only)."""


def _ring_geoms(obj: Any, name: str, files: dict[str, bytes], margin: float) -> Any:
    return [f'<geom name="{name}" type="sphere" size="{obj.radius}"/>'], ""


def _ring_primitive(obj: Any) -> tuple[str, Any]:
    return "sphere", (np.asarray(obj.center), 2 * float(obj.radius))


def test_a_new_kind_reaches_every_site_through_its_declaration() -> None:
    from redservo.physics.scenes import _object_geoms
    from redservo.scene import Scene
    from redservo.viewer.playback import Playback

    FeatureKind(
        "ring",
        type("RingFeature", (SphereFeature,), {}),
        schema=f"{__name__}:_RingSpec",
        obj=f"{__name__}:_Ring",
        mujoco=f"{__name__}:_ring_geoms",
        viewer=f"{__name__}:_ring_primitive",
    )
    try:
        ring = _Ring("r", radius=0.2)
        assert _object_geoms(ring, "r", {}, 0.05) == (
            ['<geom name="r" type="sphere" size="0.2"/>'],
            "",
        )
        assert object_adapter(ring, "render") is not None  # not declared: the sphere's (its base)
        scene = Scene([ring])
        pb = object.__new__(Playback)
        pb.__dict__["exp"] = type("E", (), {"scene": scene})()
        ((name, prim, (centre, radius)),) = pb._geometry
        assert (name, prim, radius) == ("r", "sphere", 0.4)
        np.testing.assert_array_equal(centre, np.zeros(3))
        assert isinstance(make_feature("ring", radius=0.1), SphereFeature)
        assert "ring" in feature_kinds()
    finally:
        forget_feature("ring")


def test_a_bad_declaration_is_one_clear_error() -> None:
    with pytest.raises(ConfigurationError, match="mujoco 'nowhere' is not 'module:attribute'"):
        FeatureKind("x", SphereFeature, schema="a:B", mujoco="nowhere")
    with pytest.raises(ConfigurationError, match="'sphere' is already declared by SphereFeature"):
        FeatureKind("sphere", type("Other", (SphereFeature,), {}), schema="a:B")
