"""Schema of the ``[[features]]`` entries of a scenario, one spec per feature kind.

Each spec has a ``kind`` literal, its keys, the object kind it observes, its size (known
without building, so that ``components`` and ``task.desired`` are checked when the file is
validated) and :meth:`FeatureSpec.features`, which builds the runtime features through
:func:`redservo.features.make_feature`. A feature kind declares its spec
(``FeatureKind.schema``, :mod:`redservo.features.kinds`); :data:`FEATURE_KINDS` lists them.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal, cast, get_args

import numpy as np
from pydantic import Field, model_validator

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.features import feature_kinds
from redservo.features.base import Feature
from redservo.features.kinds import FeatureKind, on_change, resolve
from redservo.features.moments import RotationFeatures
from redservo.features.pose import RotationVariant, TranslationVariant
from redservo.features.sphere import SphereVariant
from redservo.scene import SceneObject
from redservo.schema.base import Doc, Table, choice, fail, integer, tagged_union
from redservo.schema.scene import ObjectSpec

__all__ = ["FEATURE_KINDS", "AnyFeature", "FeatureSpec"]


_Components = Annotated[
    list[Annotated[int, Field(ge=0, le=1000)]],
    Field(min_length=1, max_length=1000),
    Doc("array of distinct integers >= 0"),
]


class FeatureSpec(Table):
    """Keys every feature has."""

    kind: str
    object: str = Field(min_length=1, description="name of the object it observes")
    components: _Components | None = Field(
        None,
        description="keep only these components in the task (0-based, in the feature's order): "
        "e1 = C (s - s*), J1 = C L J with C a selection matrix; s is still measured in full",
    )
    object_kind: ClassVar[str] = "points"
    """The object kind this feature observes."""

    @model_validator(mode="after")
    def _distinct(self) -> FeatureSpec:
        if self.components is not None and len(set(self.components)) != len(self.components):
            fail(f"components must be distinct, got {self.components}", "components")
        return self

    def observes(self, kind: str) -> bool:
        """Whether this feature can observe an object of ``kind``."""
        return kind == self.object_kind

    def size(self, obj: ObjectSpec) -> int:
        """Number of components of one feature of this entry (per point for ``point``)."""
        raise NotImplementedError  # pragma: no cover - abstract

    def count(self, obj: ObjectSpec) -> int:
        """Number of features this entry expands to (one per point for ``point``)."""
        return 1

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        """The runtime features observing ``obj`` (``desired``: ``c*Mo`` per object, or None)."""
        raise NotImplementedError  # pragma: no cover - abstract


def _feature(kind: str, **options: Any) -> Feature:
    from redservo.features import make_feature

    return make_feature(kind, **options)


class PointSpec(FeatureSpec):
    """Image point(s) ``(x, y)`` of a ``points`` object: one feature per point."""

    kind: Literal["point"]
    index: int | None = integer(
        None,
        ge=0,
        le=9_999,
        description="only this point of the set (0-based; default: every point)",
    )

    def observes(self, kind: str) -> bool:
        return kind in ("points", "tag")  # a tag's points are its corners

    def size(self, obj: ObjectSpec) -> int:
        return 2

    def count(self, obj: ObjectSpec) -> int:
        if self.index is not None:
            return 1
        return 4 if obj.kind == "tag" else len(getattr(obj, "points", [[0.0]]))

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        pts = np.asarray(cast(Any, obj).points, dtype=np.float64)
        idx = [self.index] if self.index is not None else range(pts.shape[0])
        return [_feature("point", point_o=pts[j]) for j in idx]


class LineSpec(FeatureSpec):
    """``(ρ, θ)`` of a straight line."""

    kind: Literal["line"]
    object_kind: ClassVar[str] = "line"

    def size(self, obj: ObjectSpec) -> int:
        return 2

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        o: Any = obj
        return [_feature("line", point=o.point, direction=o.direction)]


class CylinderSpec(FeatureSpec):
    """``(ρ1, θ1, ρ2, θ2)`` of a cylinder's two limb lines."""

    kind: Literal["cylinder"]
    object_kind: ClassVar[str] = "cylinder"

    def size(self, obj: ObjectSpec) -> int:
        return 4

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        o: Any = obj
        return [_feature("cylinder", radius=o.radius, axis=o.axis, point=o.point)]


class SphereSpec(FeatureSpec):
    """The ellipse of a sphere (variants in :mod:`redservo.features.sphere`)."""

    kind: Literal["sphere"]
    object_kind: ClassVar[str] = "sphere"
    variant: SphereVariant = choice(
        "exact",
        what="sphere variant",
        description="exact (xc, yc, a) | paper (CM01 eq. 27) | moments (xc, yc, n20, n11, n02)",
    )

    def size(self, obj: ObjectSpec) -> int:
        return 5 if self.variant == "moments" else 3

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        o: Any = obj
        return [_feature("sphere", radius=o.radius, center=o.center, variant=self.variant)]


class MomentsSpec(FeatureSpec):
    """The six decoupled moment features of a planar ``points`` object (needs
    ``task.desired_pose``)."""

    kind: Literal["moments"]
    rotation_features: RotationFeatures = choice(
        "c4c6", what="rotation features", description="the last two features: c4c6 | pxpy | sxsy"
    )

    def size(self, obj: ObjectSpec) -> int:
        return 6

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        from redservo.features import MomentFeatures

        assert desired is not None  # checked by the scenario schema
        pts = np.asarray(cast(Any, obj).points, dtype=np.float64)
        T = desired[obj.name]
        target = MomentFeatures.desired_from(pts @ T[:3, :3].T + T[:3, 3])
        return [
            _feature(
                "moments",
                points_o=pts,
                desired_area=target[0],
                desired_depth=target[1],
                rotation_features=self.rotation_features,
            )
        ]


class _PoseSpec(FeatureSpec):
    """A pose-based feature of any object (its frame's pose, :mod:`redservo.features.pose`)."""

    object_kind: ClassVar[str] = "any"

    def observes(self, kind: str) -> bool:
        return True

    def size(self, obj: ObjectSpec) -> int:
        return 3

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        variant = cast(Any, self).variant
        cdMo = None if desired is None else desired.get(obj.name)
        return [_feature(self.kind, variant=variant, desired=cdMo)]


class LogDepthSpec(FeatureSpec):
    """``log Z`` of one point of a ``points`` or ``tag`` object (the 2½-D task's depth
    component, error ``log(Z/Z*)``)."""

    kind: Literal["log_depth"]
    index: int = integer(0, ge=0, le=9_999, description="the point of the set (0-based)")

    def observes(self, kind: str) -> bool:
        return kind in ("points", "tag")

    def size(self, obj: ObjectSpec) -> int:
        return 1

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        pts = np.asarray(cast(Any, obj).points, dtype=np.float64)
        return [_feature("log_depth", point_o=pts[self.index])]


class PoseTranslationSpec(_PoseSpec):
    """Translation ``t`` of a pose (PBVS): ``cdMc`` (the camera in the desired frame, s* = 0),
    ``cMo`` (the object in the camera frame) or ``cMcd``; cdMc and cMcd need
    ``task.desired_pose``."""

    kind: Literal["pose_translation"]
    variant: TranslationVariant = choice(
        "cdMc", what="translation variant", description="cdMc | cMo | cMcd"
    )


class PoseThetaUSpec(_PoseSpec):
    """Rotation ``θu`` of ``c*R_c`` (``cdRc``) or ``c R_c*`` (``cRcd``) (PBVS); needs
    ``task.desired_pose``."""

    kind: Literal["pose_thetau"]
    variant: RotationVariant = choice("cdRc", what="rotation variant", description="cdRc | cRcd")


FEATURE_KINDS: dict[str, type[FeatureSpec]] = {
    name: resolve(kind.schema) for name, kind in feature_kinds().items()
}
"""Feature kinds of ``[[features]]``, by ``kind``: the spec each declared feature kind names
(``FeatureKind.schema``, :mod:`redservo.features.kinds`); a kind declared later joins it
(:func:`_changed`)."""
if TYPE_CHECKING:
    AnyFeature = FeatureSpec
else:
    AnyFeature = tagged_union(FEATURE_KINDS, default=None, what="feature kind")


def _spec(kind: FeatureKind) -> type[FeatureSpec]:
    """The spec ``kind`` names.

    Raises:
        ConfigurationError: it is not a :class:`FeatureSpec` of ``kind = <its name>``.
    """
    spec = resolve(kind.schema)
    literal = getattr(getattr(spec, "model_fields", {}).get("kind"), "annotation", None)
    if not (isinstance(spec, type) and issubclass(spec, FeatureSpec)) or get_args(literal) != (
        kind.name,
    ):
        raise ConfigurationError(
            f"FeatureKind {kind.name!r}: schema {kind.schema!r} must be a subclass of "
            f"redservo.schema.features.FeatureSpec with kind: Literal[{kind.name!r}]",
            argument="schema",
        )
    return spec


def _changed() -> None:
    """The declared kinds changed after this module was imported (a user's file declared or
    forgot one): :data:`FEATURE_KINDS` follows, :data:`AnyFeature` is rebuilt and so is the
    scenario's schema when it is built already (:class:`redservo.schema.scenario.ScenarioSpec`).

    Raises:
        ConfigurationError: a spec is not a :class:`FeatureSpec` of its kind's name (nothing
            changes).
    """
    global AnyFeature
    specs = {name: _spec(kind) for name, kind in feature_kinds().items()}
    FEATURE_KINDS.clear()
    FEATURE_KINDS.update(specs)
    AnyFeature = tagged_union(FEATURE_KINDS, default=None, what="feature kind")
    scenario = sys.modules.get("redservo.schema.scenario")
    if scenario is not None:
        model = scenario.ScenarioSpec
        model.model_fields["features"].annotation = list[AnyFeature]
        model.model_rebuild(force=True)


on_change(_changed)
