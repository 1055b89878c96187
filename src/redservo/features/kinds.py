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

* the feature's own adapters, looked up by the feature's class (:func:`feature_adapter`)
  by the sites that measure or draw a feature from an image (``""``: not measured there):

  - ``image_term(i, feature, target, scene, sets, depth) -> TermState``: how the image
    sensor plans term ``i`` (:mod:`redservo.vision.sensor`; ``sets``: the point sets whose
    dots the sensor tracks, :func:`redservo.vision.measure.dots_term`);
  - ``measure_image(sensor, feature, st, image, set_xy, truth, notes, i) -> s | None``: its
    value in the image (:mod:`redservo.vision.measure`); ``measure_mujoco``: the same in the
    MuJoCo camera's image when it differs (:mod:`redservo.physics.camera`);
  - ``depth(feature, s, *, set_points, set_xy) -> inv_depth``: its inverse-depth
    parameters estimated from ``s`` (``depth = "estimated"``, :mod:`redservo.vision.depth`);
  - ``draw(img, optics, feature, s, color)``: its overlay in the video
    (:mod:`redservo.vision.video`).

:func:`redservo.features.make_feature` and :data:`redservo.features.FEATURES` come from
this registry too. The tag (a point set drawn as a marker) keeps its own adapters in the
vision and physics modules: no feature kind owns it.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, get_args

from redservo.errors import ConfigurationError

__all__ = [
    "SHIPPED",
    "FeatureKind",
    "feature_adapter",
    "feature_kind",
    "feature_kinds",
    "forget_feature",
    "object_adapter",
    "on_change",
    "register_feature",
    "resolve",
]

Role = Literal["render", "mujoco", "viewer"]
FeatureRole = Literal["image_term", "measure_image", "measure_mujoco", "depth", "draw"]
_REFS = ("schema", "obj", "render", "mujoco", "viewer", *get_args(FeatureRole))


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
    image_term: str = ""
    """How the image sensor plans a term of this kind (``""``: not measured in images)."""
    measure_image: str = ""
    """Its value measured in the rendered image."""
    measure_mujoco: str = ""
    """Its value in the MuJoCo camera's image (``""``: as ``measure_image``)."""
    depth: str = ""
    """Its inverse depth estimated from its value (``""``: no known size)."""
    draw: str = ""
    """Its overlay in the video (``""``: not drawn)."""

    def __post_init__(self) -> None:
        for field in _REFS:
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
        try:
            _changed()
        except BaseException:  # not declared after all: as it was before
            if known is None:
                del _KINDS[self.name]
            else:
                _KINDS[self.name] = known
            _changed()
            raise


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
_FEATURE_ADAPTERS: dict[tuple[type, str], Callable[..., Any] | None] = {}
_LISTENERS: list[Callable[[], None]] = []


def on_change(listener: Callable[[], None]) -> None:
    """Call ``listener()`` whenever a kind is declared or forgotten from now on (the scenario
    schema rebuilds its ``[[features]]`` union: :mod:`redservo.schema.features`); what it
    raises refuses the declaration."""
    _LISTENERS.append(listener)


def _changed() -> None:
    _ADAPTERS.clear()
    _FEATURE_ADAPTERS.clear()
    for listener in _LISTENERS:
        listener()


def forget_feature(name: str) -> None:
    """Undeclare the kind ``name`` (a user's kind, e.g. at the end of a test); nothing when it
    is not declared.

    Raises:
        ConfigurationError: ``name`` is a shipped kind (:data:`SHIPPED`).
    """
    if name in SHIPPED:
        raise ConfigurationError(f"{name!r} is a shipped feature kind", argument="name")
    if _KINDS.pop(name, None) is not None:
        _changed()


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


def feature_kind(feature: object) -> FeatureKind | None:
    """The kind declared for the nearest class of ``feature`` (its own, then its bases);
    None when no kind is."""
    by_class = {kind.feature: kind for kind in _KINDS.values()}
    return next((by_class[c] for c in type(feature).__mro__ if c in by_class), None)


def feature_adapter(feature: object, role: FeatureRole) -> Callable[..., Any] | None:
    """The ``role`` adapter of ``feature``: the one its kind declares (:func:`feature_kind`),
    resolved once; None when its kind declares none (or it has no kind)."""
    key = (type(feature), role)
    if key not in _FEATURE_ADAPTERS:
        kind = feature_kind(feature)
        ref = "" if kind is None else getattr(kind, role)
        _FEATURE_ADAPTERS[key] = resolve(ref) if ref else None
    return _FEATURE_ADAPTERS[key]


def register_feature(
    name: str, feature: type[Any], schema: str | type[Any], **refs: str | Callable[..., Any]
) -> FeatureKind:
    """Declare the feature kind ``name`` from anywhere (a user's file too): as
    :class:`FeatureKind`, with its spec and adapters given as ``"module:attribute"`` or as the
    module-level class or function itself. Its spec joins the scenario's ``[[features]]``
    even when the schema is already built (:mod:`redservo.schema.features`).

    Raises:
        ConfigurationError: a name taken by another class, an unknown adapter role, an object
            that is not a module-level class or function, or a spec that is not a
            :class:`~redservo.schema.features.FeatureSpec` of kind ``name``.
    """
    roles = set(_REFS) - {"schema"}
    unknown = sorted(set(refs) - roles)
    if unknown:
        raise ConfigurationError(
            f"register_feature {name!r}: unknown adapter role(s) {', '.join(unknown)}; "
            f"allowed: {', '.join(sorted(roles))}",
            argument=unknown[0],
        )
    named = {role: _ref_of(role, ref) for role, ref in refs.items()}
    return FeatureKind(name, feature, schema=_ref_of("schema", schema), **named)


def _ref_of(role: str, ref: str | Callable[..., Any] | type[Any]) -> str:
    """``ref`` as ``"module:attribute"`` (a string as it is; a class or a function by its
    module and name, when it is that module's attribute)."""
    if isinstance(ref, str):
        return ref
    module, name = getattr(ref, "__module__", ""), getattr(ref, "__qualname__", "")
    if not (module and name.isidentifier()):
        raise ConfigurationError(
            f"register_feature: {role} {ref!r} is not a module-level class or function; "
            "give it as 'module:attribute'",
            argument=role,
        )
    return f"{module}:{name}"
