"""References between the tables of a scenario, checked when the file is validated.

A feature names an existing object of the right kind, a point index exists, the selected
components exist, ``task.desired`` has one value per feature component, moments and
``depth = desired | mean`` have a desired pose, the occluder is a sphere and its target a
point set. Nothing is built: the sizes come from the feature specs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from redservo.schema.base import fail, unknown_name

if TYPE_CHECKING:  # pragma: no cover
    from redservo.schema.scenario import ScenarioSpec
    from redservo.schema.scene import ObjectSpec

__all__ = ["check_references"]


def _objects(spec: ScenarioSpec) -> dict[str, ObjectSpec]:
    out: dict[str, ObjectSpec] = {}
    for i, obj in enumerate(spec.objects):
        if obj.name in out:
            fail(f"duplicate object name {obj.name!r} (names must be unique)", f"objects[{i}].name")
        out[obj.name] = obj
    return out


def _features(spec: ScenarioSpec, objects: dict[str, ObjectSpec]) -> int:
    """Check every ``[[features]]`` entry; return the number of stacked components."""
    total = 0
    for i, feat in enumerate(spec.features):
        where = f"features[{i}]"
        obj = objects.get(feat.object)
        if obj is None:
            fail(unknown_name("object", feat.object, list(objects)), f"{where}.object")
        if not feat.observes(obj.kind):
            fail(
                f"a {feat.kind} feature observes a '{feat.object_kind}' object; "
                f"{obj.name!r} is a '{obj.kind}' object",
                f"{where}.kind",
            )
        index = getattr(feat, "index", None)
        n_points = 4 if obj.kind == "tag" else len(getattr(obj, "points", []))
        if index is not None and index >= n_points:
            fail(
                f"must be in [0, {n_points - 1}] ({obj.name!r} has {n_points} points), got {index}",
                f"{where}.index",
            )
        size = feat.size(obj)
        if feat.components is not None and max(feat.components) >= size:
            fail(
                f"components must be distinct indices in [0, {size - 1}] (the feature has "
                f"{size} components), got {feat.components}",
                f"{where}.components",
            )
        if feat.kind == "moments" and spec.task.desired_pose is None:
            fail("moment features need task.desired_pose (c*Mo of the target)", "task.desired_pose")
        needs_pose = feat.kind.startswith("pose_") and getattr(feat, "variant", "") != "cMo"
        if needs_pose and spec.task.desired_pose is None:
            fail(f"{feat.kind} features need task.desired_pose (c*Mo)", "task.desired_pose")
        total += size * feat.count(obj)
    return total


def _task(spec: ScenarioSpec, size: int) -> None:
    task = spec.task
    if task.desired is None and task.desired_pose is None:
        fail("give task.desired_pose (c*Mo of the target) or task.desired (s*)", "task")
    if task.desired is not None and task.desired_pose is not None:
        fail("give either desired (s*) or desired_pose, not both", "task.desired")
    if task.desired is not None and len(task.desired) != size:
        fail(
            f"expected {size} values (one per feature component, stacked in feature order), "
            f"got {len(task.desired)}",
            "task.desired",
        )
    if task.depth != "current" and task.desired_pose is None:
        fail(f"depth = {task.depth!r} needs task.desired_pose", "task.depth")
    sensor = spec.sensor
    if sensor.kind == "image" and sensor.depth == "desired" and task.desired_pose is None:
        fail(
            "depth = 'desired' (the default) needs task.desired_pose; give it, or use "
            "'estimated' or 'true'",
            "sensor.depth",
        )


def _occlusion(spec: ScenarioSpec, objects: dict[str, ObjectSpec]) -> None:
    occ = spec.occlusion
    if occ is None:
        return
    for key, name, kind in (("occluder", occ.occluder, "sphere"), ("target", occ.target, "points")):
        obj = objects.get(name)
        if obj is None:
            fail(unknown_name("object", name, list(objects)), f"occlusion.{key}")
        if obj.kind != kind:
            fail(
                f"must name a '{kind}' object; {name!r} is a '{obj.kind}' object",
                f"occlusion.{key}",
            )


def _obstacle_names(spec: ScenarioSpec) -> None:
    seen: set[str] = set()
    for i, ob in enumerate(spec.obstacles):
        if ob.name in seen:
            fail(
                f"duplicate obstacle name {ob.name!r} (names must be unique)",
                f"obstacles[{i}].name",
            )
        seen.add(ob.name)


def check_references(spec: ScenarioSpec) -> None:
    """Raise a validation error (key relative to the file) for the first broken reference."""
    from redservo.schema.sensor import check_timing

    _obstacle_names(spec)
    check_timing(spec)
    objects = _objects(spec)
    size = _features(spec, objects)
    _task(spec, size)
    _occlusion(spec, objects)
