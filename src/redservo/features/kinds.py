"""One declaration per feature kind: its class, its scenario entry and the adapters of the
scene object it observes.

A feature module declares its kind beside its class (``KIND = FeatureKind(...)``), which
registers it here. Everything else names by ``"module:attribute"`` (resolved on first use, so
that importing a feature never imports pydantic, MuJoCo, the viewer or the renderer):

* ``schema``: its ``[[features]]`` spec (:class:`redservo.schema.features.FeatureSpec`):
  :data:`redservo.schema.features.FEATURE_KINDS` lists the declared kinds;
* ``obj``: the scene object class it observes (:mod:`redservo.scene`). A kind that owns
  that object also declares the object's adapters, which the dispatching sites look up by
  the object's class (:func:`object_adapter`) instead of testing its type:

  - ``render(obj, cMo, optics, levels) -> Layer | list[Layer] | None``: its layers in the
    rendered camera image (:func:`redservo.vision.shapes.scene_layers`);
  - ``mujoco(obj, name, files, paper_margin) -> (geoms | None, assets)``: its geometry in
    the MuJoCo scene (:mod:`redservo.physics.scenes`);
  - ``viewer(obj) -> (primitive, geometry)``: what the 3-D viewer draws, a primitive of
    ``"points"`` ((k, 3) m), ``"sphere"`` ((centre, radius), m) or a segment kind
    (``"line"``, ``"cylinder"``: (point, direction, radius), m) in the object frame
    (:mod:`redservo.viewer.playback`).

:func:`redservo.features.make_feature` and :data:`redservo.features.FEATURES` come from
this registry too. The tag (a point set drawn as a marker) keeps its own adapters in the
vision and physics modules: no feature kind owns it.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from redservo.errors import ConfigurationError

__all__ = ["SHIPPED", "FeatureKind", "feature_kinds", "object_adapter", "resolve"]

Role = Literal["render", "mujoco", "viewer"]


@dataclass(frozen=True)
class FeatureKind:
    """A feature kind (module docstring); declaring it registers it.

    Raises:
        ConfigurationError: the name is taken by another class, or a reference is not
            ``"module:attribute"``.
    """

    name: str
    """Its ``kind`` in a scenario and in :func:`redservo.features.make_feature`."""
    feature: type[Any]
    """Its :class:`~redservo.features.Feature` class."""
    schema: str
    """Its ``[[features]]`` spec, ``"module:Class"``."""
    obj: str = ""
    """The scene object class it observes (``""``: none, e.g. a pose)."""
    render: str = ""
    """The object's image layers (``""``: the object is not drawn or another kind draws it)."""
    mujoco: str = ""
    """The object's MuJoCo geometry."""
    viewer: str = ""
    """The object's 3-D viewer primitive."""

    def __post_init__(self) -> None:
        for field in ("schema", "obj", "render", "mujoco", "viewer"):
            ref = getattr(self, field)
            if ref and not _is_ref(ref):
                raise ConfigurationError(
                    f"FeatureKind {self.name!r}: {field} {ref!r} is not 'module:attribute'",
                    argument=field,
                )
        known = _KINDS.get(self.name)
        if known is not None and known.feature is not self.feature:
            raise ConfigurationError(
                f"FeatureKind: kind {self.name!r} is already declared by {known.feature.__name__}",
                argument="name",
            )
        _KINDS[self.name] = self
        _ADAPTERS.clear()


SHIPPED = (
    "point",
    "line",
    "cylinder",
    "sphere",
    "moments",
    "pose_translation",
    "pose_thetau",
    "log_depth",
)
"""The order of the shipped kinds (in :data:`redservo.features.FEATURES`, messages and
docs); kinds declared elsewhere follow in declaration order."""

_KINDS: dict[str, FeatureKind] = {}
_ADAPTERS: dict[tuple[type, str], Callable[..., Any] | None] = {}


def _is_ref(ref: str) -> bool:
    module, _, attr = ref.partition(":")
    return bool(module) and attr.isidentifier()


def resolve(ref: str) -> Any:
    """The object named ``"module:attribute"`` (imports the module)."""
    module, _, attr = ref.partition(":")
    return getattr(importlib.import_module(module), attr)


def feature_kinds() -> dict[str, FeatureKind]:
    """The declared kinds by name, the shipped ones first (in :data:`SHIPPED` order), then
    in declaration order. The shipped kinds are declared when :mod:`redservo.features` is
    imported: use this function and :func:`object_adapter` from there."""
    rank = {name: i for i, name in enumerate(SHIPPED)}
    names = sorted(_KINDS, key=lambda name: rank.get(name, len(rank)))  # stable: then in order
    return {name: _KINDS[name] for name in names}


def object_adapter(obj: object, role: Role) -> Callable[..., Any] | None:
    """The ``role`` adapter of the scene object ``obj``: the one declared by the kind that
    observes the nearest class of ``obj`` (its own, then its bases) and declares ``role``;
    None when no kind does."""
    key = (type(obj), role)
    if key not in _ADAPTERS:
        owners: dict[type, str] = {}
        for kind in feature_kinds().values():
            if kind.obj and getattr(kind, role):
                owners.setdefault(resolve(kind.obj), getattr(kind, role))
        ref = next((owners[c] for c in type(obj).__mro__ if c in owners), None)
        _ADAPTERS[key] = None if ref is None else resolve(ref)
    return _ADAPTERS[key]
