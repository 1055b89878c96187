"""Scenario files: one TOML file fully describes one experiment.

The format is documented, with a fully commented example, in
``docs/scenarios.md``. :func:`load_scenario` parses and validates a file (or a
shipped scenario name) and :func:`build` turns it into the objects
:func:`redservo.simulation.simulate` needs. Every validation error is a
:class:`~redservo.errors.ScenarioError` that names the file, the key and what
is allowed.
"""

from __future__ import annotations

import copy
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import RedservoError, ScenarioError

__all__ = [
    "Scenario",
    "apply_overrides",
    "load_scenario",
    "parse_scenario",
    "shipped_scenarios",
]

_SCHEMA: dict[str, Any] = {
    "name": str,
    "description": str,
    "paper": str,
    "robot": {
        "model": str,
        "options": dict,
        "q0": list,
        "start_pose": dict,
        "q_guess": list,
        "rho": float,
        "q_min": list,
        "q_max": list,
        "qdot_max": (float, list),
        "qddot_max": (float, list),
        "margin": float,
    },
    "camera": {"px": float, "py": float, "u0": float, "v0": float, "width": int, "height": int},
    "objects": list,
    "features": list,
    "task": {"desired_pose": dict, "desired": list, "depth": str},
    "control": {
        "method": str,
        "lam": float,
        "gain": {"zero": float, "inf": float, "slope": float},
        "dt": float,
        "options": dict,
        "shield": bool,
        "robust": bool,
        "scaling": str,
    },
    "simulation": {
        "max_iterations": int,
        "tolerance": float,
        "qdot_max": (float, list),
        "noise_std": float,
        "seed": int,
        "depth_scale": float,
        "eMc_error": dict,
        "feedforward": str,
        "image_margin_px": float,
        "check_image": bool,
        "stop_at_convergence": bool,
        "min_margin": float,
    },
    "actuators": {
        "tau": (float, list),
        "delay_steps": int,
        "qdot_max": (float, list),
        "qddot_max": (float, list),
        "encoder_resolution": (float, list),
        "encoder_noise_std": (float, list),
        "seed": int,
    },
    "occlusion": {
        "occluder": str,
        "target": str,
        "beta": float,
        "gain": float,
        "avoid": bool,
    },
}
_REQUIRED = {"robot": ("model",), "control": ("method",)}
_OBJECT_KEYS = {
    "name": str,
    "kind": str,
    "points": list,
    "radius": float,
    "center": list,
    "axis": list,
    "point": list,
    "direction": list,
    "pose": dict,
    "pose_in_camera": dict,
    "motion": dict,
}
_OBJECT_KINDS = ("points", "sphere", "cylinder", "line")
_MOTION_KEYS = {
    "kind": str,
    "velocity": list,
    "angular_velocity": list,
    "times": list,
    "translations": list,
    "rotvecs": list,
}
_FEATURE_KEYS = {
    "kind": str,
    "object": str,
    "variant": str,
    "index": int,
    "rotation_features": str,
    "components": list,
}
_POSE_KEYS = {"translation": list, "rotvec": list, "rpy_deg": list}


def _type_name(t: Any) -> str:
    if isinstance(t, tuple):
        return " or ".join(_type_name(x) for x in t)
    return {
        str: "string",
        float: "number",
        int: "integer",
        bool: "boolean",
        list: "array",
        dict: "table",
    }[t]


def _type_ok(value: Any, t: Any) -> bool:
    if isinstance(t, tuple):
        return any(_type_ok(value, x) for x in t)
    if t is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if t is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, t)


@dataclass
class Scenario:
    """A parsed, validated scenario: the raw table and where it came from.

    Attributes:
        data: The validated TOML table (defaults are applied by :func:`build`).
        source: File path or ``shipped:NAME``.
    """

    data: dict[str, Any]
    source: str
    name: str = field(init=False)

    def __post_init__(self) -> None:
        self.name = str(self.data.get("name") or Path(self.source).stem)

    def error(self, key: str, message: str) -> ScenarioError:
        """Return a ScenarioError naming this file and ``key``."""
        return ScenarioError(f"{self.source}: key '{key}': {message}")

    @property
    def method(self) -> str:
        """The control method name."""
        return str(self.data["control"]["method"])


def shipped_scenarios() -> dict[str, str]:
    """Return ``{name: description}`` of the scenarios shipped in ``redservo/scenarios``."""
    return shipped_descriptions("scenarios")


def shipped_descriptions(folder: str) -> dict[str, str]:
    """Return ``{name: description}`` of the TOML files in the package folder ``folder``."""
    out: dict[str, str] = {}
    root = resources.files("redservo").joinpath(*folder.split("/"))
    if not root.is_dir():  # pragma: no cover - the folders are shipped
        return out
    for entry in sorted(root.iterdir(), key=lambda p: p.name):
        if entry.name.endswith(".toml"):
            try:
                data = tomllib.loads(entry.read_text())
            except tomllib.TOMLDecodeError:  # pragma: no cover - shipped files are tested
                continue
            out[entry.name[:-5]] = str(data.get("description", ""))
    return out


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a scenario by shipped name (``redservo list``) or by path to a TOML file.

    Raises:
        ScenarioError: the file is missing, not valid TOML, or fails validation.
    """
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise ScenarioError(f"{path}: no such scenario file")
        text, source = path.read_text(), str(path)
    else:
        res = resources.files("redservo") / "scenarios" / f"{name_or_path}.toml"
        if not res.is_file():
            known = ", ".join(shipped_scenarios())
            raise ScenarioError(
                f"unknown scenario {str(name_or_path)!r}: not a file and not a shipped scenario; "
                f"shipped scenarios: {known}"
            )
        text, source = res.read_text(), f"shipped:{name_or_path}"
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    return parse_scenario(data, source)


def parse_scenario(data: Mapping[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a scenario table (keys, types, names, q0 within limits) and return it."""
    table = copy.deepcopy(dict(data))
    _check_table(table, _SCHEMA, "", source)
    for section, keys in _REQUIRED.items():
        if section not in table:
            raise ScenarioError(f"{source}: key '{section}': missing required table [{section}]")
        for key in keys:
            if key not in table[section]:
                raise ScenarioError(f"{source}: key '{section}.{key}': missing required key")
    for where, obj in _entries(table, "objects", _OBJECT_KEYS, ("name", "kind"), source):
        if obj["kind"] not in _OBJECT_KINDS:
            raise ScenarioError(
                f"{source}: key '{where}.kind': unknown object kind {obj['kind']!r}; "
                f"allowed: {', '.join(_OBJECT_KINDS)}"
            )
        for pose_key in ("pose", "pose_in_camera"):
            if pose_key in obj:
                _check_table(obj[pose_key], _POSE_KEYS, f"{where}.{pose_key}.", source)
        if "motion" in obj:
            _check_table(obj["motion"], _MOTION_KEYS, f"{where}.motion.", source)
    names = [o["name"] for o in table.get("objects", [])]
    for where, feat in _entries(table, "features", _FEATURE_KEYS, ("kind", "object"), source):
        if feat["object"] not in names:
            raise ScenarioError(
                f"{source}: key '{where}.object': unknown object {feat['object']!r}; "
                f"objects defined: {', '.join(names) or '(none)'}"
            )
    if not table.get("features"):
        raise ScenarioError(f"{source}: key 'features': at least one [[features]] entry is needed")
    scenario = Scenario(table, source)
    _check_names(scenario)
    # Building validates q0, poses, features and options: errors name this file.
    from redservo.experiment import build

    try:
        build(scenario)
    except ScenarioError:
        raise
    except RedservoError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    return scenario


def _entries(
    table: Mapping[str, Any],
    section: str,
    schema: Mapping[str, Any],
    required: tuple[str, ...],
    source: str,
) -> list[tuple[str, dict[str, Any]]]:
    """Validate an array of tables (``[[objects]]``, ``[[features]]``); return ``(key, entry)``."""
    out = []
    for i, entry in enumerate(table.get(section, [])):
        where = f"{section}[{i}]"
        if not isinstance(entry, dict):
            raise ScenarioError(f"{source}: key '{where}': expected a table, got {entry!r}")
        _check_table(entry, schema, where + ".", source)
        for key in required:
            if key not in entry:
                raise ScenarioError(f"{source}: key '{where}.{key}': missing required key")
        out.append((where, entry))
    return out


def _check_table(table: Any, schema: Mapping[str, Any], prefix: str, source: str) -> None:
    if not isinstance(table, dict):
        raise ScenarioError(f"{source}: key '{prefix.rstrip('.')}': expected a table")
    for key, value in table.items():
        if key not in schema:
            allowed = ", ".join(sorted(schema))
            raise ScenarioError(
                f"{source}: key '{prefix}{key}': unknown key; allowed here: {allowed}"
            )
        want = schema[key]
        if isinstance(want, dict):
            _check_table(value, want, f"{prefix}{key}.", source)
        elif not _type_ok(value, want):
            raise ScenarioError(
                f"{source}: key '{prefix}{key}': expected {_type_name(want)}, "
                f"got {type(value).__name__} {value!r}"
            )


def _check_names(sc: Scenario) -> None:
    from redservo.features import FEATURES
    from redservo.redundancy import METHODS
    from redservo.robots import ROBOTS

    d = sc.data
    if d["robot"]["model"] not in ROBOTS:
        raise sc.error(
            "robot.model", f"unknown robot {d['robot']['model']!r}; allowed: {', '.join(ROBOTS)}"
        )
    if d["control"]["method"] not in METHODS:
        raise sc.error(
            "control.method",
            f"unknown method {d['control']['method']!r}; allowed: {', '.join(METHODS)}",
        )
    for i, feat in enumerate(d.get("features", [])):
        if feat["kind"] not in FEATURES:
            raise sc.error(
                f"features[{i}].kind",
                f"unknown feature {feat['kind']!r}; allowed: {', '.join(FEATURES)}",
            )
    depth = d.get("task", {}).get("depth", "current")
    if depth not in ("current", "desired", "mean"):
        raise sc.error("task.depth", f"unknown depth {depth!r}; allowed: current, desired, mean")


_INDEXED_KEY = re.compile(r"([A-Za-z_][A-Za-z0-9_-]*)\[([0-9]+)\]")
"""A ``--set`` path segment ``name[i]``: entry i of an array of tables."""


def apply_overrides(scenario: Scenario, assignments: list[str]) -> Scenario:
    """Return a new scenario with ``key=value`` overrides applied (``--set`` on the CLI).

    Keys are dotted paths (``control.lam``, ``control.options.alpha``,
    ``simulation.max_iterations``); a path segment ``name[i]`` selects entry ``i``
    (0-based) of an array of tables (``features[0].variant``,
    ``objects[1].radius``); values are TOML values (``0.5``, ``"gpm"``,
    ``[0.1, 0.2]``, ``true``); a bare word is taken as a string.

    Raises:
        ScenarioError: malformed assignment, an index that does not name an existing
            table of an array, or the result fails validation.
    """
    data = copy.deepcopy(scenario.data)
    for item in assignments:
        if "=" not in item:
            raise ScenarioError(f"--set {item!r}: expected key=value, e.g. control.lam=0.5")
        key, raw = item.split("=", 1)
        key = key.strip()
        try:
            value = tomllib.loads(f"v = {raw}")["v"]
        except tomllib.TOMLDecodeError:
            value = raw.strip()
        node = data
        parts = key.split(".")
        for part in parts[:-1]:
            indexed = _INDEXED_KEY.fullmatch(part)
            if indexed is not None:
                name, i = indexed.group(1), int(indexed.group(2))
                seq = node.get(name)
                if not isinstance(seq, list) or i >= len(seq) or not isinstance(seq[i], dict):
                    size = len(seq) if isinstance(seq, list) else 0
                    allowed = f"indices 0 to {size - 1}" if size else f"no '{name}' tables"
                    raise ScenarioError(f"--set {item!r}: '{part}' does not exist; {allowed}")
                node = seq[i]
                continue
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise ScenarioError(f"--set {item!r}: '{part}' is not a table")
            node = nxt
        node[parts[-1]] = value
    return parse_scenario(data, f"{scenario.source} (with --set {' '.join(assignments)})")


def pose_from_table(table: Mapping[str, Any], where: str, sc: Scenario) -> FloatArray:
    """Build a 4x4 transform from ``{translation, rotvec | rpy_deg}``."""
    from redservo.spatial import make_transform, rpy_to_matrix

    t = np.asarray(table.get("translation", [0.0, 0.0, 0.0]), dtype=float)
    if t.shape != (3,):
        raise sc.error(
            f"{where}.translation", f"expected 3 numbers, got {table.get('translation')!r}"
        )
    if "rotvec" in table and "rpy_deg" in table:
        raise sc.error(where, "give either rotvec or rpy_deg, not both")
    if "rpy_deg" in table:
        r = np.asarray(table["rpy_deg"], dtype=float)
        if r.shape != (3,):
            raise sc.error(f"{where}.rpy_deg", "expected 3 numbers (roll, pitch, yaw in degrees)")
        return make_transform(rpy_to_matrix(r, degrees=True), t)
    rv = np.asarray(table.get("rotvec", [0.0, 0.0, 0.0]), dtype=float)
    if rv.shape != (3,):
        raise sc.error(f"{where}.rotvec", f"expected 3 numbers, got {table.get('rotvec')!r}")
    return make_transform(t=t, rotvec=rv)
