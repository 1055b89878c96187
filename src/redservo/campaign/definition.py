"""The campaign definition: TOML format, parsing and validation.

The format is documented in the module docstring of :mod:`redservo.campaign`.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Any, Literal, NamedTuple

from redservo._validation import FloatArray
from redservo.errors import RedservoError, ScenarioError
from redservo.limits import JointLimits
from redservo.scenario import Scenario, load_scenario, parse_scenario, shipped_descriptions

FORMAT_VERSION = 2
"""Version of the sampling algorithm and the row format, part of the fingerprint."""

Range = tuple[float, float]


@dataclass(frozen=True)
class StartSpec:
    """Start configurations near the limits (module docstring, "Start configurations").

    Attributes:
        p_band: Probability that an eligible joint starts in the outer band, in [0, 1].
        band_beyond: Width of the strip inside the threshold, in units of ``rho`` (>= 0).
        min_margin: Smallest distance to a real limit, fraction of the range (>= 0).
        min_in_band: At least this many joints start in the outer band.
        joints: Names of the eligible joints (None = all).
    """

    p_band: float = 0.5
    band_beyond: float = 0.5
    min_margin: float = 0.01
    min_in_band: int = 1
    joints: tuple[str, ...] | None = None


@dataclass(frozen=True)
class TargetSpec:
    """Random placement of the scene relative to the start camera (module docstring).

    Attributes:
        translation: Three ``(lo, hi)`` ranges (m), start camera axes.
        rotation_deg: Three ``(lo, hi)`` ranges (deg) of the rotation-vector components,
            reference-object axes.
        image_margin_px: Required distance of the start image to the border (px).
        motion_frame: ``"camera"`` or ``"world"``: what object motions are kept relative to.
    """

    translation: tuple[Range, Range, Range] = ((0.0, 0.0), (0.0, 0.0), (0.0, 0.0))
    rotation_deg: tuple[Range, Range, Range] = ((0.0, 0.0), (0.0, 0.0), (0.0, 0.0))
    image_margin_px: float = 10.0
    motion_frame: Literal["camera", "world"] = "camera"


@dataclass(frozen=True)
class ErrorSpec:
    """Noise and modelling errors; None / 0 leaves the scenario's value.

    Attributes:
        noise_std: ``(lo, hi)`` range of the feature-noise standard deviation (feature units).
        depth_scale: ``(lo, hi)`` range of the controller's depth scale ``Ẑ/Z``.
        hand_eye_translation: Half-width (m) of each hand-eye translation error component.
        hand_eye_rotation_deg: Half-width (deg) of each hand-eye rotation-vector component.
    """

    noise_std: Range | None = None
    depth_scale: Range | None = None
    hand_eye_translation: float = 0.0
    hand_eye_rotation_deg: float = 0.0


class _Nominal(NamedTuple):
    """What every sample derives from: the base scenario evaluated at its own start."""

    limits: JointLimits
    joint_names: tuple[str, ...]
    eligible: tuple[int, ...]
    bRc: FloatArray  # (3, 3) nominal start camera orientation
    cMo: dict[str, FloatArray]  # nominal object poses in the start camera frame
    reference: str
    fkine: Callable[[FloatArray], FloatArray]


@dataclass(frozen=True, eq=False)
class CampaignDefinition:
    """A parsed, validated campaign definition (see the module docstring for the format).

    Attributes:
        name: Campaign name.
        description: One line.
        source: File path or ``shipped:NAME``.
        scenario: The base scenario, overrides applied.
        methods: Default methods.
        method_options: Law options per method name.
        samples: Default number of samples.
        start: :class:`StartSpec`.
        target: :class:`TargetSpec`.
        errors: :class:`ErrorSpec`.
        max_attempts: Draws per sample before giving up.
        data: The raw TOML table.
    """

    name: str
    description: str
    source: str
    scenario: Scenario
    methods: tuple[str, ...]
    method_options: Mapping[str, Mapping[str, Any]]
    samples: int
    start: StartSpec
    target: TargetSpec
    errors: ErrorSpec
    max_attempts: int
    data: Mapping[str, Any] = field(repr=False)

    def fingerprint(self, seed: int) -> str:
        """SHA-256 (hex) of what the rows depend on: definition, base scenario, seed, format."""
        table = {
            k: v for k, v in self.data.items() if k not in ("methods", "samples", "description")
        }
        blob = json.dumps(
            {
                "format": FORMAT_VERSION,
                "seed": int(seed),
                "definition": table,
                "scenario": self.scenario.data,
            },
            sort_keys=True,
            separators=(",", ":"),
            default=str,
        )
        return hashlib.sha256(blob.encode()).hexdigest()

    @cached_property
    def nominal(self) -> _Nominal:
        """The base scenario evaluated at its own start (cached)."""
        from redservo.experiment import build

        exp = build(self.scenario)
        bMc = exp.robot.fkine(exp.q0)
        cMo = {name: exp.scene.cMo(name, bMc, 0.0) for name in exp.scene.names}
        names = exp.robot.joint_names
        eligible = (
            tuple(range(len(names)))
            if self.start.joints is None
            else tuple(names.index(j) for j in self.start.joints)
        )
        robot = exp.robot

        def fkine(q: FloatArray) -> FloatArray:
            return robot.fkine(q, check_limits=False)

        ref = str(self.scenario.data["features"][0]["object"])
        return _Nominal(exp.limits, names, eligible, bMc[:3, :3].copy(), cMo, ref, fkine)


_TOP_KEYS = {
    "name": str,
    "description": str,
    "scenario": str,
    "samples": int,
    "methods": list,
    "max_attempts": int,
    "overrides": dict,
    "method_options": dict,
    "start": dict,
    "target": dict,
    "errors": dict,
}
_START_KEYS = {
    "p_band": float,
    "band_beyond": float,
    "min_margin": float,
    "min_in_band": int,
    "joints": list,
}
_TARGET_KEYS = {
    "translation": list,
    "rotation_deg": list,
    "image_margin_px": float,
    "motion_frame": str,
}
_ERROR_KEYS = {
    "noise_std": (float, list),
    "depth_scale": (float, list),
    "hand_eye_translation": float,
    "hand_eye_rotation_deg": float,
}
_TYPE_NAMES = {
    str: "a string",
    int: "an integer",
    float: "a number",
    list: "an array",
    dict: "a table",
}


def _is(value: Any, kind: Any) -> bool:
    if isinstance(kind, tuple):
        return any(_is(value, k) for k in kind)
    if isinstance(value, bool):
        return False
    if kind is float:
        return isinstance(value, int | float) and math.isfinite(value)
    return isinstance(value, kind)


def _check_keys(table: Mapping[str, Any], schema: Mapping[str, Any], prefix: str, src: str) -> None:
    for key, value in table.items():
        if key not in schema:
            raise ScenarioError(
                f"{src}: key '{prefix}{key}': unknown key; allowed here: {', '.join(sorted(schema))}"
            )
        want = schema[key]
        if not _is(value, want):
            kinds = want if isinstance(want, tuple) else (want,)
            allowed = " or ".join(_TYPE_NAMES[k] for k in kinds)
            raise ScenarioError(f"{src}: key '{prefix}{key}': expected {allowed}, got {value!r}")


def _range(value: Any, key: str, src: str, *, low: float | None = None) -> Range:
    """A number ``h`` (meaning ``[-h, h]``, or ``[h, h]`` when ``low`` is given) or ``[lo, hi]``."""
    if _is(value, float):
        v = float(value)
        lo, hi = (v, v) if low is not None else (-abs(v), abs(v))
    elif isinstance(value, list) and len(value) == 2 and all(_is(x, float) for x in value):
        lo, hi = float(value[0]), float(value[1])
    else:
        raise ScenarioError(
            f"{src}: key '{key}': expected a number or a [lo, hi] pair of numbers, got {value!r}"
        )
    if lo > hi:
        raise ScenarioError(f"{src}: key '{key}': lo > hi in {value!r}")
    if low is not None and lo < low:
        raise ScenarioError(f"{src}: key '{key}': values must be >= {low}, got {value!r}")
    return lo, hi


def _ranges3(value: Any, key: str, src: str) -> tuple[Range, Range, Range]:
    if not (isinstance(value, list) and len(value) == 3):
        raise ScenarioError(
            f"{src}: key '{key}': expected 3 entries (one per axis), each ±h or [lo, hi], "
            f"got {value!r}"
        )
    r = [_range(v, f"{key}[{i}]", src) for i, v in enumerate(value)]
    return r[0], r[1], r[2]


def _merge(base: dict[str, Any], extra: Mapping[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in extra.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def shipped_campaigns() -> dict[str, str]:
    """Return ``{name: description}`` of the campaigns in ``redservo/scenarios/campaigns``."""
    return shipped_descriptions("scenarios/campaigns")


def load_campaign(name_or_path: str | Path) -> CampaignDefinition:
    """Load a campaign definition by shipped name or by path to a TOML file.

    Raises:
        ScenarioError: missing file, invalid TOML, or a key fails validation (the message
            names the file and the key).
    """
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise ScenarioError(f"{path}: no such campaign file")
        text, source, base_dir = path.read_text(), str(path), path.parent
    else:
        res = resources.files("redservo") / "scenarios" / "campaigns" / f"{name_or_path}.toml"
        if not res.is_file():
            known = ", ".join(shipped_campaigns()) or "(none)"
            raise ScenarioError(
                f"unknown campaign {str(name_or_path)!r}: not a file and not a shipped campaign; "
                f"shipped campaigns: {known}"
            )
        text, source, base_dir = res.read_text(), f"shipped:campaigns/{name_or_path}", None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    return parse_campaign(data, source, base_dir=base_dir)


def parse_campaign(
    data: Mapping[str, Any], source: str = "<campaign>", *, base_dir: Path | None = None
) -> CampaignDefinition:
    """Validate a campaign table and return the definition.

    Args:
        data: The TOML table.
        source: Where it came from (used in error messages).
        base_dir: Directory against which a relative ``scenario`` path is resolved
            (None: the current directory).

    Raises:
        ScenarioError: naming ``source`` and the offending key.
    """
    from redservo.redundancy import METHODS, make_law

    src = source
    table = copy.deepcopy(dict(data))
    _check_keys(table, _TOP_KEYS, "", src)
    if "scenario" not in table:
        raise ScenarioError(f"{src}: key 'scenario': missing (a shipped scenario name or a path)")
    # -- base scenario -------------------------------------------------------------------------
    ref = table["scenario"]
    ref_path = Path(ref)
    if ref.endswith(".toml") and not ref_path.is_absolute() and base_dir is not None:
        ref_path = base_dir / ref_path
    try:
        base = load_scenario(ref_path if ref.endswith(".toml") else ref)
    except ScenarioError as exc:
        raise ScenarioError(f"{src}: key 'scenario': {exc}") from None
    if table.get("overrides"):
        try:
            base = parse_scenario(
                _merge(base.data, table["overrides"]), f"{base.source} (overrides from {src})"
            )
        except ScenarioError as exc:
            raise ScenarioError(f"{src}: key 'overrides': {exc}") from None
    # -- methods -------------------------------------------------------------------------------
    methods = table.get("methods", list(METHODS))
    if not methods:
        raise ScenarioError(f"{src}: key 'methods': give at least one method")
    for i, m in enumerate(methods):
        if m not in METHODS:
            raise ScenarioError(
                f"{src}: key 'methods[{i}]': unknown method {m!r}; allowed: {', '.join(METHODS)}"
            )
    if len(set(methods)) != len(methods):
        raise ScenarioError(f"{src}: key 'methods': a method is listed twice: {methods}")
    options: dict[str, dict[str, Any]] = {}
    for m, opts in table.get("method_options", {}).items():
        key = f"method_options.{m}"
        if m not in METHODS:
            raise ScenarioError(
                f"{src}: key '{key}': unknown method {m!r}; allowed: {', '.join(METHODS)}"
            )
        if not isinstance(opts, dict):
            raise ScenarioError(f"{src}: key '{key}': expected a table of law options")
        try:
            make_law(m, **opts)
        except RedservoError as exc:
            raise ScenarioError(f"{src}: key '{key}': {exc}") from None
        except TypeError as exc:  # an option the law's constructor does not take
            raise ScenarioError(f"{src}: key '{key}': {exc}") from None
        options[m] = dict(opts)
    samples = int(table.get("samples", 100))
    if samples < 1:
        raise ScenarioError(f"{src}: key 'samples': must be at least 1, got {samples}")
    max_attempts = int(table.get("max_attempts", 100))
    if max_attempts < 1:
        raise ScenarioError(f"{src}: key 'max_attempts': must be at least 1, got {max_attempts}")
    # -- variation spec ------------------------------------------------------------------------
    start = _parse_start(table.get("start", {}), base, src)
    target = _parse_target(table.get("target", {}), src)
    errors = _parse_errors(table.get("errors", {}), src)
    name = str(table.get("name") or Path(source).stem)
    return CampaignDefinition(
        name=name,
        description=str(table.get("description", "")),
        source=source,
        scenario=base,
        methods=tuple(methods),
        method_options=options,
        samples=samples,
        start=start,
        target=target,
        errors=errors,
        max_attempts=max_attempts,
        data=table,
    )


def _parse_start(t: Mapping[str, Any], base: Scenario, src: str) -> StartSpec:
    from redservo.robots import make_robot

    _check_keys(t, _START_KEYS, "start.", src)
    spec = StartSpec(
        p_band=float(t.get("p_band", 0.5)),
        band_beyond=float(t.get("band_beyond", 0.5)),
        min_margin=float(t.get("min_margin", 0.01)),
        min_in_band=int(t.get("min_in_band", 1)),
        joints=tuple(str(j) for j in t["joints"]) if "joints" in t else None,
    )
    rho = float(base.data["robot"].get("rho", 0.1))
    robot = base.data["robot"]
    names = make_robot(robot["model"], **robot.get("options", {})).joint_names
    if not 0.0 <= spec.p_band <= 1.0:
        raise ScenarioError(f"{src}: key 'start.p_band': must be in [0, 1], got {spec.p_band}")
    outer = (1.0 + spec.band_beyond) * rho
    if spec.band_beyond < 0.0 or outer >= 0.5:
        raise ScenarioError(
            f"{src}: key 'start.band_beyond': must be >= 0 with (1 + band_beyond) rho < 0.5 "
            f"(rho = {rho} from the scenario), got {spec.band_beyond}"
        )
    if not 0.0 <= spec.min_margin < outer:
        raise ScenarioError(
            f"{src}: key 'start.min_margin': must be in [0, (1 + band_beyond) rho = {outer:.4g}) "
            f"(fraction of the range), got {spec.min_margin}"
        )
    if spec.joints is not None:
        for i, j in enumerate(spec.joints):
            if j not in names:
                raise ScenarioError(
                    f"{src}: key 'start.joints[{i}]': unknown joint {j!r}; joints of "
                    f"{robot['model']}: {', '.join(names)}"
                )
    n_eligible = len(names) if spec.joints is None else len(set(spec.joints))
    if not 0 <= spec.min_in_band <= n_eligible:
        raise ScenarioError(
            f"{src}: key 'start.min_in_band': must be in [0, {n_eligible}] (the eligible "
            f"joints), got {spec.min_in_band}"
        )
    return spec


def _parse_target(t: Mapping[str, Any], src: str) -> TargetSpec:
    _check_keys(t, _TARGET_KEYS, "target.", src)
    zero = ((0.0, 0.0), (0.0, 0.0), (0.0, 0.0))
    frame = t.get("motion_frame", "camera")
    if frame not in ("camera", "world"):
        raise ScenarioError(
            f"{src}: key 'target.motion_frame': must be 'camera' or 'world', got {frame!r}"
        )
    margin = float(t.get("image_margin_px", 10.0))
    if margin < 0:
        raise ScenarioError(f"{src}: key 'target.image_margin_px': must be >= 0, got {margin}")
    return TargetSpec(
        translation=_ranges3(t["translation"], "target.translation", src)
        if "translation" in t
        else zero,
        rotation_deg=_ranges3(t["rotation_deg"], "target.rotation_deg", src)
        if "rotation_deg" in t
        else zero,
        image_margin_px=margin,
        motion_frame=frame,
    )


def _parse_errors(t: Mapping[str, Any], src: str) -> ErrorSpec:
    _check_keys(t, _ERROR_KEYS, "errors.", src)
    noise = _range(t["noise_std"], "errors.noise_std", src, low=0.0) if "noise_std" in t else None
    depth = None
    if "depth_scale" in t:
        depth = _range(t["depth_scale"], "errors.depth_scale", src, low=0.0)
        if depth[0] <= 0.0:
            raise ScenarioError(f"{src}: key 'errors.depth_scale': must be positive, got {depth}")
    spec = ErrorSpec(
        noise_std=noise,
        depth_scale=depth,
        hand_eye_translation=float(t.get("hand_eye_translation", 0.0)),
        hand_eye_rotation_deg=float(t.get("hand_eye_rotation_deg", 0.0)),
    )
    for key in ("hand_eye_translation", "hand_eye_rotation_deg"):
        if getattr(spec, key) < 0:
            raise ScenarioError(f"{src}: key 'errors.{key}': must be >= 0 (a half-width)")
    return spec
