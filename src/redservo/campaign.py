"""Monte Carlo comparison campaigns: every method on the same random variations of a scenario.

A *campaign definition* (TOML; shipped in ``redservo/scenarios/campaigns/`` and loadable by
name, or any path) names a base scenario and says how to vary it. :func:`run_campaign` draws
``N`` variations from a seed, runs every method on each of them (the same variations for all
methods), appends one row per (sample, method) to ``samples.csv`` as soon as it is finished,
and summarizes each method. This is the benchmark literature.md §C recommends: random starts
near the limits; success = task converged with no limit crossed.

Definition format (every table is optional except ``scenario``)::

    name = "cm01-gaze"
    description = "one line"
    scenario = "cm01-gaze"          # shipped scenario name, or a .toml path relative to this file
    samples = 200                   # default N (run_campaign(samples=...) overrides)
    methods = ["classical", "gpm"]  # default methods (default: every name in redservo.METHODS)
    max_attempts = 100              # draws per sample before giving up (see "Invalid starts")

    [overrides]                     # deep-merged into the base scenario (e.g. an iteration cap)
    simulation = { max_iterations = 400 }

    [method_options.gpm]            # law options of one method; a method without an entry
    alpha = 2.0                     # gets the scenario's control.options if it is the
                                    # scenario's own method, and no options otherwise

    [start]                         # start configuration near the limits (see below)
    p_band = 0.5                    # probability that a joint starts in the outer band
    band_beyond = 0.5               # band reaches (1 + band_beyond) rho into the range
    min_margin = 0.01               # distance to the real limit, fraction of the range
    min_in_band = 1                 # at least this many joints start in the band
    joints = ["x", "z", "B"]        # joints that may start in the band (default: all)

    [target]                        # random placement relative to the start camera
    translation = [0.1, 0.1, [-0.1, 0.3]]  # per camera axis: ±h or [lo, hi] (m)
    rotation_deg = [10, 10, 30]            # per target axis: ±h or [lo, hi] (deg)
    image_margin_px = 10                   # the start image must be this far inside the border
    motion_frame = "camera"                # "camera" or "world" (see below)

    [errors]                        # noise and modelling errors, each optional
    noise_std = [0.0, 0.002]        # feature noise std (feature units): number or [lo, hi]
    depth_scale = [0.7, 1.3]        # controller depth Ẑ = depth_scale · Z: number or [lo, hi]
    hand_eye_translation = 0.01     # ± per axis (m) of the hand-eye error
    hand_eye_rotation_deg = 1.0     # ± per rotation-vector component (deg)

Start configurations (``[start]``). With ``Δq̄`` the range of a joint and ``rho`` the base
scenario's band width (the activation threshold ``q̃`` lies at margin ``rho``, CM01 eq. 3),
the *outer band* is the set of positions whose margin (distance to the nearer real limit over
``Δq̄``) lies in ``[min_margin, (1 + band_beyond) rho]``: the whole activation band plus a
strip ``band_beyond · rho`` wide just inside the threshold. Each eligible joint independently
starts in the outer band with probability ``p_band`` (side chosen with probability 1/2, margin
uniform in the interval); if fewer than ``min_in_band`` did, further eligible joints are chosen
uniformly until there are that many. Every other joint is uniform in the *inner range*
``[q̄_min + (1 + band_beyond) rho Δq̄, q̄_max - (1 + band_beyond) rho Δq̄]``. So every start is
legal by at least ``min_margin · Δq̄`` on every joint. :func:`sample_start` is this sampler.

Target placement (``[target]``). The base scenario is run at its own start to get every
object's pose in the start camera frame, ``cMo``. A sample keeps those relative poses and
applies one rigid perturbation to the whole scene: a rotation by the rotation vector ``r``
(components uniform in the ``rotation_deg`` ranges, converted to rad) about the origin and axes
of the *reference object* (the object of the first feature), then a translation ``t`` (uniform
in the ``translation`` ranges) expressed in the start camera frame::

    cMo_i' = T(t) · cMref · R(r) · cMref⁻¹ · cMo_i

The sample's scenario gives each object as ``pose_in_camera = cMo_i'`` and the robot as
``q0 = sampled q``; the desired pose (relative to the reference object) is unchanged. Object
motions (``constant_velocity``, ``waypoints``) are given in the world frame; with
``motion_frame = "camera"`` (default) their vectors are rotated by ``bRc' · bRc⁻¹`` (new and
nominal start camera orientations) so that the motion *relative to the start camera* is the
nominal one, which keeps a tracked target in view whatever the start; ``"world"`` keeps them.

Invalid starts. A drawn sample is *invalid* when the task cannot be evaluated at its start
(target behind the camera, degenerate features) or when an object is not inside the image by
``image_margin_px`` (the larger of ``[target].image_margin_px`` and the scenario's
``simulation.image_margin_px``) or is occluded. The check is the simulator's own: one
iteration of ``classical`` must not end in ``target_lost`` or ``occluded``. An invalid draw is
re-drawn deterministically: attempt ``a`` of sample ``i`` uses the generator seeded by
``SeedSequence(seed, spawn_key=(i, a))``, ``a = 0, 1, ...``; the number of rejected draws is
stored in the ``attempts`` column. After ``max_attempts`` rejections a
:class:`~redservo.errors.ScenarioError` says the variation spec is too wide.

Determinism and resumption. A sample depends only on ``(definition, seed, index)``, so the
rows do not depend on the number of workers or on the order runs finish. With an output
directory, every finished row is appended to ``samples.csv`` (flushed at once) and the
definition's fingerprint (SHA-256 of the canonical JSON of the definition, the base scenario
after overrides, the seed and :data:`FORMAT_VERSION`; not ``methods``, ``samples`` or
``description``) is stored in ``definition.json``. A rerun in the same directory reuses every
stored row and computes only the missing (sample, method) pairs, so adding samples or methods
extends a campaign; a different fingerprint is refused with a
:class:`~redservo.errors.ConfigurationError`. A run that raised an exception is stored with
outcome ``error`` (and the message in ``error``), counted as a failure, and recomputed on the
next rerun.

Statistics (per method, over the first ``samples`` samples). Success = outcome ``converged``
(the simulator stops a run at the first limit crossing or lost target, so a converged run
never hit a limit nor lost the target). The success rate has a 95 % Wilson score interval
(:func:`wilson_interval`). Iterations to converge: median and 90th percentile over successes.
Peak joint speed (largest ``|q̇_i|`` over joints and time, rad/s or m/s: CM01's Afma6 mixes
both), peak camera translation (m/s) and rotation (rad/s) speed: median and 95th percentile
over all runs (a failed run counts with the peak it reached before it stopped). Discontinuity
(max ``‖Δq̇‖`` between steps) and minimum margin (fraction of the range): medians over all
runs. Percentiles use numpy's default (linear interpolation).

Decisions (for docs/decisions.md):
    * The outer band is measured from the real limit in units of the range and extends
      ``band_beyond · rho`` past the threshold, so the set-up is robot-independent and always
      includes starts just outside the band, where a law must *not* yet react.
    * The scene is perturbed rigidly relative to the start camera (not in the world): a random
      start configuration then never puts the target behind the camera by construction, and
      the required camera displacement has the same distribution for every start.
    * Peaks over all runs (not only successes), so a method is not rewarded for failing early.
    * ``success`` needs no separate "target lost" or "limit" check: those outcomes end the run.
"""

from __future__ import annotations

import copy
import csv
import hashlib
import io
import json
import math
import os
import sys
import tomllib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from datetime import UTC, datetime
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, RedservoError, ScenarioError, UnknownNameError
from redservo.limits import JointLimits
from redservo.scenario import Scenario, load_scenario, parse_scenario, shipped_descriptions
from redservo.spatial import inverse, make_transform, matrix_to_rotvec

__all__ = [
    "FORMAT_VERSION",
    "CampaignDefinition",
    "CampaignResult",
    "ErrorSpec",
    "MethodStats",
    "Sample",
    "StartSpec",
    "TargetSpec",
    "draw_sample",
    "load_campaign",
    "method_stats",
    "parse_campaign",
    "run_campaign",
    "sample_start",
    "shipped_campaigns",
    "stats_table",
    "wilson_interval",
]

FORMAT_VERSION = 1
"""Version of the sampling algorithm and the row format, part of the fingerprint."""

Z95 = 1.959963984540054
"""The 0.975 quantile of the standard normal distribution (two-sided 95 %)."""

Range = tuple[float, float]
BoolArray = NDArray[np.bool_]


# --------------------------------------------------------------------------- definition


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


# --------------------------------------------------------------------------- sampling


def sample_start(
    limits: JointLimits,
    rng: np.random.Generator,
    *,
    p_band: float,
    band_beyond: float,
    min_margin: float,
    min_in_band: int = 0,
    eligible: Sequence[int] | None = None,
) -> tuple[FloatArray, BoolArray]:
    """Draw a start configuration near the limits (module docstring, "Start configurations").

    Args:
        limits: Joint limits; their ``rho`` places the activation thresholds.
        rng: Random generator.
        p_band: Probability that an eligible joint starts in the outer band.
        band_beyond: Strip inside the threshold, in units of ``rho``.
        min_margin: Smallest distance to a real limit, fraction of the range.
        min_in_band: At least this many eligible joints start in the outer band.
        eligible: Indices of the joints that may start in the band (None = all).

    Returns:
        ``(q, near)``: (n,) configuration (m or rad) and (n,) booleans, True for the joints
        drawn in the outer band (margin in ``[min_margin, (1 + band_beyond) rho]``); the
        others have a margin of at least ``(1 + band_beyond) rho``.

    Raises:
        ConfigurationError: the band does not fit (``(1 + band_beyond) rho >= 1/2``),
            ``min_margin`` is outside ``[0, (1 + band_beyond) rho)``, ``p_band`` outside
            [0, 1], or ``min_in_band`` exceeds the eligible joints.
    """
    n = limits.n
    idx = np.arange(n) if eligible is None else np.unique(np.asarray(eligible, dtype=int))
    outer = (1.0 + band_beyond) * limits.rho
    if band_beyond < 0 or outer >= 0.5:
        raise ConfigurationError(
            f"band_beyond must be >= 0 with (1 + band_beyond) rho < 0.5, got {band_beyond} "
            f"with rho = {limits.rho}"
        )
    if not 0.0 <= min_margin < outer:
        raise ConfigurationError(f"min_margin must be in [0, {outer:.4g}), got {min_margin}")
    if not 0.0 <= p_band <= 1.0:
        raise ConfigurationError(f"p_band must be in [0, 1], got {p_band}")
    if idx.size and (idx[0] < 0 or idx[-1] >= n):
        raise ConfigurationError(f"eligible joints must be in [0, {n - 1}], got {eligible}")
    if not 0 <= min_in_band <= idx.size:
        raise ConfigurationError(
            f"min_in_band must be in [0, {idx.size}] (the eligible joints), got {min_in_band}"
        )
    near = np.zeros(n, dtype=bool)
    near[idx] = rng.random(idx.size) < p_band
    short = min_in_band - int(near.sum())
    if short > 0:
        free = idx[~near[idx]]
        near[rng.choice(free, size=short, replace=False)] = True
    margin = rng.uniform(min_margin, outer, n)
    upper = rng.random(n) < 0.5
    lo_in = limits.q_min + outer * limits.range
    hi_in = limits.q_max - outer * limits.range
    inner = lo_in + rng.random(n) * (hi_in - lo_in)
    in_band = np.where(
        upper, limits.q_max - margin * limits.range, limits.q_min + margin * limits.range
    )
    return np.where(near, in_band, inner), near


class Sample(NamedTuple):
    """One valid random variation of the base scenario.

    Attributes:
        number: Sample index.
        attempts: Number of rejected (invalid) draws before this one.
        q0: (n,) start configuration (m or rad).
        near: (n,) True for the joints drawn in the outer band.
        translation: (3,) scene translation in the start camera frame (m).
        rotation_deg: (3,) rotation vector about the reference object's axes (deg).
        noise_std: Feature noise standard deviation (feature units).
        depth_scale: Controller depth scale.
        noise_seed: Seed of the feature noise.
        hand_eye_translation: (3,) hand-eye translation error (m).
        hand_eye_rotation_deg: (3,) hand-eye rotation-vector error (deg).
        scenario: The sample's scenario.
    """

    number: int
    attempts: int
    q0: FloatArray
    near: BoolArray
    translation: FloatArray
    rotation_deg: FloatArray
    noise_std: float
    depth_scale: float
    noise_seed: int
    hand_eye_translation: FloatArray
    hand_eye_rotation_deg: FloatArray
    scenario: Scenario


def _uniform3(rng: np.random.Generator, ranges: Sequence[Range]) -> FloatArray:
    lo = np.array([r[0] for r in ranges])
    hi = np.array([r[1] for r in ranges])
    return np.asarray(lo + rng.random(3) * (hi - lo))


def _rotate_motion(motion: dict[str, Any], M: FloatArray) -> dict[str, Any]:
    out = dict(motion)
    for key in ("velocity", "angular_velocity"):
        if key in out:
            out[key] = (M @ np.asarray(out[key], dtype=float)).tolist()
    for key in ("translations", "rotvecs"):
        if key in out:
            out[key] = (np.asarray(out[key], dtype=float) @ M.T).tolist()
    return out


def _draw(defn: CampaignDefinition, seed: int, index: int, attempt: int) -> Sample:
    nom = defn.nominal
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index, attempt)))
    st, tg, er = defn.start, defn.target, defn.errors
    q0, near = sample_start(
        nom.limits,
        rng,
        p_band=st.p_band,
        band_beyond=st.band_beyond,
        min_margin=st.min_margin,
        min_in_band=st.min_in_band,
        eligible=nom.eligible,
    )
    t = _uniform3(rng, tg.translation)
    r_deg = _uniform3(rng, tg.rotation_deg)
    noise = float(rng.uniform(*er.noise_std)) if er.noise_std else None
    depth = float(rng.uniform(*er.depth_scale)) if er.depth_scale else None
    he_t = rng.uniform(-1.0, 1.0, 3) * er.hand_eye_translation + 0.0  # + 0.0: no -0.0
    he_r = rng.uniform(-1.0, 1.0, 3) * er.hand_eye_rotation_deg + 0.0
    noise_seed = int(rng.integers(0, 2**31 - 1))
    # The scenario of this sample.
    data = copy.deepcopy(defn.scenario.data)
    robot = data["robot"]
    for key in ("start_pose", "q_guess"):
        robot.pop(key, None)
    robot["q0"] = q0.tolist()
    cMref = nom.cMo[nom.reference]
    D = make_transform(t=t) @ cMref @ make_transform(rotvec=np.radians(r_deg)) @ inverse(cMref)
    M = nom.fkine(q0)[:3, :3] @ nom.bRc.T
    for obj in data.get("objects", []):
        obj.pop("pose", None)
        P = D @ nom.cMo[obj["name"]]
        obj["pose_in_camera"] = {
            "translation": P[:3, 3].tolist(),
            "rotvec": matrix_to_rotvec(P[:3, :3]).tolist(),
        }
        if "motion" in obj and tg.motion_frame == "camera":
            obj["motion"] = _rotate_motion(obj["motion"], M)
    sim = data.setdefault("simulation", {})
    if noise is not None:
        sim["noise_std"] = noise
        sim["seed"] = noise_seed
    if depth is not None:
        sim["depth_scale"] = depth
    if er.hand_eye_translation > 0 or er.hand_eye_rotation_deg > 0:
        sim["eMc_error"] = {"translation": he_t.tolist(), "rotvec": np.radians(he_r).tolist()}
    sc = Scenario(data, f"{defn.source} sample {index} (attempt {attempt})")
    return Sample(
        number=index,
        attempts=attempt,
        q0=q0,
        near=near,
        translation=t,
        rotation_deg=r_deg,
        noise_std=float(sim.get("noise_std", 0.0)),
        depth_scale=float(sim.get("depth_scale", 1.0)),
        noise_seed=int(sim.get("seed", 0)),
        hand_eye_translation=he_t,
        hand_eye_rotation_deg=he_r,
        scenario=sc,
    )


def _start_problem(defn: CampaignDefinition, sc: Scenario) -> str | None:
    """Why the sample's start is invalid, or None (module docstring, "Invalid starts")."""
    from redservo.experiment import build

    try:
        exp = build(sc)
    except RedservoError as exc:
        return str(exc)
    margin = max(exp.options.image_margin_px, defn.target.image_margin_px)
    res = exp.run(
        method="classical",
        law_options={},
        max_iterations=1,
        image_margin_px=margin,
        check_image=True,
    )
    if res.outcome in ("target_lost", "occluded"):
        return f"{res.outcome} at the start (image margin {margin:g} px)"
    return None


def draw_sample(defn: CampaignDefinition, seed: int, index: int) -> Sample:
    """Draw the valid sample ``index`` of a campaign, deterministically from ``seed``.

    Attempt ``a`` uses ``SeedSequence(seed, spawn_key=(index, a))``; invalid starts are
    re-drawn (module docstring, "Invalid starts").

    Raises:
        ScenarioError: no valid start in ``defn.max_attempts`` draws.
    """
    last = ""
    for attempt in range(defn.max_attempts):
        sample = _draw(defn, seed, index, attempt)
        problem = _start_problem(defn, sample.scenario)
        if problem is None:
            return sample
        last = problem
    raise ScenarioError(
        f"{defn.source}: key 'target': sample {index}: no valid start in {defn.max_attempts} "
        f"draws (last: {last}); narrow the [target] ranges or raise max_attempts"
    )


# --------------------------------------------------------------------------- rows


def _columns(joint_names: Sequence[str]) -> list[tuple[str, str]]:
    """``(column, type)`` of ``samples.csv``; types: int, float, str, bool, int? (optional)."""
    xyz = ("x", "y", "z")
    return [
        ("sample", "int"),
        ("method", "str"),
        ("attempts", "int"),
        *((f"q0_{j}", "float") for j in joint_names),
        ("n_near", "int"),
        ("near_joints", "str"),
        *((f"target_t{a}", "float") for a in xyz),
        *((f"target_r{a}_deg", "float") for a in xyz),
        ("noise_std", "float"),
        ("noise_seed", "int"),
        ("depth_scale", "float"),
        *((f"hand_eye_t{a}", "float") for a in xyz),
        *((f"hand_eye_r{a}_deg", "float") for a in xyz),
        ("outcome", "str"),
        ("success", "bool"),
        ("iterations", "int"),
        ("limit_axis", "int?"),
        ("limit_joint", "str"),
        ("limit_iteration", "int?"),
        ("min_margin", "float"),
        ("max_joint_speed", "float"),
        ("max_cam_translation", "float"),
        ("max_cam_rotation", "float"),
        ("discontinuity", "float"),
        ("final_error", "float"),
        ("error", "str"),
    ]


def _sample_columns(s: Sample, joint_names: Sequence[str]) -> dict[str, Any]:
    xyz = ("x", "y", "z")
    row: dict[str, Any] = {"sample": s.number, "attempts": s.attempts}
    row.update({f"q0_{j}": float(v) for j, v in zip(joint_names, s.q0)})
    row["n_near"] = int(s.near.sum())
    row["near_joints"] = "+".join(j for j, b in zip(joint_names, s.near) if b)
    row.update({f"target_t{a}": float(v) for a, v in zip(xyz, s.translation)})
    row.update({f"target_r{a}_deg": float(v) for a, v in zip(xyz, s.rotation_deg)})
    row.update(noise_std=s.noise_std, noise_seed=s.noise_seed, depth_scale=s.depth_scale)
    row.update({f"hand_eye_t{a}": float(v) for a, v in zip(xyz, s.hand_eye_translation)})
    row.update({f"hand_eye_r{a}_deg": float(v) for a, v in zip(xyz, s.hand_eye_rotation_deg)})
    return row


def _summary_columns(summary: Mapping[str, Any], joint_names: Sequence[str]) -> dict[str, Any]:
    hit = summary.get("limit_hit")
    cam = summary["max_camera_speed"]
    return {
        "outcome": summary["outcome"],
        "success": summary["outcome"] == "converged",
        "iterations": int(summary["iterations"]),
        "limit_axis": int(hit["axis"]) + 1 if hit else None,
        "limit_joint": joint_names[int(hit["axis"])] if hit else "",
        "limit_iteration": int(hit["iteration"]) if hit else None,
        "min_margin": float(summary["min_margin"]),
        "max_joint_speed": float(max(summary["max_joint_speed"] or [0.0])),
        "max_cam_translation": float(cam["translation"]),
        "max_cam_rotation": float(cam["rotation"]),
        "discontinuity": float(summary["discontinuity"]),
        "final_error": float(summary["final_error_norm"]),
        "error": "",
    }


def _error_columns(exc: BaseException) -> dict[str, Any]:
    nan = float("nan")
    return {
        "outcome": "error",
        "success": False,
        "iterations": 0,
        "limit_axis": None,
        "limit_joint": "",
        "limit_iteration": None,
        "min_margin": nan,
        "max_joint_speed": nan,
        "max_cam_translation": nan,
        "max_cam_rotation": nan,
        "discontinuity": nan,
        "final_error": nan,
        "error": f"{type(exc).__name__}: {exc}",
    }


def _format(value: Any, kind: str) -> str:
    if value is None:
        return ""
    if kind == "float":
        return repr(float(value))  # shortest exact round trip
    if kind == "bool":
        return "True" if value else "False"
    return str(value)


def _parse(text: str, kind: str) -> Any:
    if kind == "float":
        return float(text)
    if kind == "int":
        return int(text)
    if kind == "int?":
        return int(text) if text else None
    if kind == "bool":
        if text not in ("True", "False"):
            raise ValueError(f"not a boolean: {text!r}")
        return text == "True"
    return text


class _Task(NamedTuple):
    sample: int
    method: str
    data: dict[str, Any]
    source: str
    law_options: dict[str, Any] | None
    params: dict[str, Any]


def _run_task(task: _Task) -> dict[str, Any]:
    """Run one (sample, method) and return its row; an exception becomes an ``error`` row."""
    from redservo.experiment import build

    row: dict[str, Any] = {"sample": task.sample, "method": task.method, **task.params}
    try:
        exp = build(Scenario(task.data, task.source))
        result = exp.run(method=task.method, law_options=task.law_options)
        row.update(_summary_columns(result.summary, exp.robot.joint_names))
    except Exception as exc:  # recorded, counted as a failure, retried on the next rerun
        row.update(_error_columns(exc))
    return row


# --------------------------------------------------------------------------- storage


class _Store:
    """``samples.csv`` plus ``definition.json`` in an output directory (append-only rows)."""

    def __init__(self, out: Path, defn: CampaignDefinition, seed: int) -> None:
        self.out = out
        self.columns = _columns(defn.nominal.joint_names)
        self.names = [c for c, _ in self.columns]
        self.csv = out / "samples.csv"
        meta_path = out / "definition.json"
        fp = defn.fingerprint(seed)
        out.mkdir(parents=True, exist_ok=True)
        if meta_path.exists():
            try:
                stored = json.loads(meta_path.read_text()).get("fingerprint")
            except (json.JSONDecodeError, AttributeError):
                stored = None
            if stored != fp:
                raise ConfigurationError(
                    f"{out} holds a campaign with another definition or seed (fingerprint "
                    f"{str(stored)[:12]} != {fp[:12]} for {defn.source} with seed {seed}); "
                    "use another output directory, or delete it to start over"
                )
        elif self.csv.exists():
            raise ConfigurationError(
                f"{self.csv} exists but {meta_path} does not: cannot tell which campaign the "
                "rows belong to; use another output directory, or delete it"
            )
        else:
            meta = {
                "fingerprint": fp,
                "seed": seed,
                "format": FORMAT_VERSION,
                "source": defn.source,
                "definition": defn.data,
                "scenario": defn.scenario.data,
            }
            meta_path.write_text(json.dumps(meta, indent=2, default=str) + "\n")
        self.rows = self._load()
        if not self.csv.exists():
            self.csv.write_text(",".join(self.names) + "\n")

    def _load(self) -> dict[tuple[int, str], dict[str, Any]]:
        rows: dict[tuple[int, str], dict[str, Any]] = {}
        if not self.csv.exists():
            return rows
        text = self.csv.read_text()
        reader = csv.reader(io.StringIO(text))
        header = next(reader, None)
        if header != self.names:
            raise ConfigurationError(
                f"{self.csv}: unexpected columns (written by another redservo version?); "
                "use another output directory, or delete it"
            )
        good = 0
        total = 0
        for fields in reader:
            total += 1
            row = self._parse_row(fields)
            if row is None:  # a line cut short by an interrupted write
                continue
            good += 1
            rows[(row["sample"], row["method"])] = row  # the last row of a pair wins
        if good != total:  # rewrite without the damaged lines
            self._rewrite(rows.values())
        return rows

    def _parse_row(self, fields: list[str]) -> dict[str, Any] | None:
        if len(fields) != len(self.columns):
            return None
        try:
            return {c: _parse(v, k) for (c, k), v in zip(self.columns, fields)}
        except ValueError:
            return None

    def _line(self, row: Mapping[str, Any]) -> str:
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(
            [_format(row.get(c), k) for c, k in self.columns]
        )
        return buf.getvalue()

    def _rewrite(self, rows: Iterable[Mapping[str, Any]]) -> None:
        tmp = self.csv.with_suffix(".csv.tmp")
        tmp.write_text(",".join(self.names) + "\n" + "".join(self._line(r) for r in rows))
        tmp.replace(self.csv)

    def normalize(self, row: Mapping[str, Any]) -> dict[str, Any]:
        """The row as it reads back from the file (so fresh and reused rows are identical)."""
        fields = next(csv.reader(io.StringIO(self._line(row))))
        parsed = self._parse_row(fields)
        assert parsed is not None
        return parsed

    def append(self, row: Mapping[str, Any]) -> None:
        with open(self.csv, "a", newline="") as fh:
            fh.write(self._line(row))
            fh.flush()
            os.fsync(fh.fileno())


# --------------------------------------------------------------------------- statistics


def wilson_interval(successes: int, n: int, *, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (Wilson 1927).

    ``(p̂ + z²/2n ± z sqrt(p̂(1-p̂)/n + z²/4n²)) / (1 + z²/n)`` with ``p̂ = successes/n``.

    Args:
        successes: Number of successes, in [0, n].
        n: Number of trials (>= 0); with n = 0 the interval is [0, 1].
        z: Normal quantile (default: 95 % two-sided).

    Raises:
        ConfigurationError: ``successes`` outside [0, n] or ``n < 0``.
    """
    if n < 0 or not 0 <= successes <= n:
        raise ConfigurationError(f"need 0 <= successes <= n, got successes={successes}, n={n}")
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1.0 + z * z / n
    center = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, center - half), min(1.0, center + half)


class MethodStats(NamedTuple):
    """Statistics of one method over a campaign (module docstring, "Statistics").

    Speeds in rad/s or m/s (joints), m/s (camera translation), rad/s (camera rotation);
    ``nan`` where there is nothing to summarize (e.g. no success).
    """

    method: str
    runs: int
    successes: int
    success_rate: float
    ci_low: float
    ci_high: float
    limit_hits: int
    target_lost: int
    max_iterations: int
    other_failures: int
    iterations_median: float
    iterations_p90: float
    joint_speed_median: float
    joint_speed_p95: float
    cam_translation_median: float
    cam_translation_p95: float
    cam_rotation_median: float
    cam_rotation_p95: float
    discontinuity_median: float
    min_margin_median: float


def _pct(values: Sequence[float], q: float) -> float:
    a = np.asarray([v for v in values if not math.isnan(v)], dtype=float)
    return float(np.percentile(a, q)) if a.size else float("nan")


def method_stats(method: str, rows: Sequence[Mapping[str, Any]]) -> MethodStats:
    """Summarize the rows of one method (rows as in ``samples.csv``)."""
    n = len(rows)
    ok = [r for r in rows if r["success"]]
    k = len(ok)
    lo, hi = wilson_interval(k, n)
    outcomes = [r["outcome"] for r in rows]

    def col(name: str, rs: Sequence[Mapping[str, Any]] = rows) -> list[float]:
        return [float(r[name]) for r in rs]

    return MethodStats(
        method=method,
        runs=n,
        successes=k,
        success_rate=k / n if n else float("nan"),
        ci_low=lo,
        ci_high=hi,
        limit_hits=outcomes.count("joint_limit"),
        target_lost=outcomes.count("target_lost"),
        max_iterations=outcomes.count("max_iterations"),
        other_failures=sum(
            o not in ("converged", "joint_limit", "target_lost", "max_iterations") for o in outcomes
        ),
        iterations_median=_pct(col("iterations", ok), 50),
        iterations_p90=_pct(col("iterations", ok), 90),
        joint_speed_median=_pct(col("max_joint_speed"), 50),
        joint_speed_p95=_pct(col("max_joint_speed"), 95),
        cam_translation_median=_pct(col("max_cam_translation"), 50),
        cam_translation_p95=_pct(col("max_cam_translation"), 95),
        cam_rotation_median=_pct(col("max_cam_rotation"), 50),
        cam_rotation_p95=_pct(col("max_cam_rotation"), 95),
        discontinuity_median=_pct(col("discontinuity"), 50),
        min_margin_median=_pct(col("min_margin"), 50),
    )


def _g(v: float, fmt: str = ".3g") -> str:
    return "—" if math.isnan(v) else format(v, fmt)


def stats_table(stats: Iterable[MethodStats]) -> str:
    """Return a markdown table, one row per method, of :class:`MethodStats`."""
    head = (
        "| method | success [95% CI] | limit hits | target lost | max. iter. | "
        "iterations med (p90) | peak q̇ med (p95) | peak cam. v (m/s) med (p95) | "
        "peak cam. ω (rad/s) med (p95) | discontinuity med | min margin med |\n"
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    lines = []
    for s in stats:
        other = f" (+{s.other_failures} errors)" if s.other_failures else ""
        lines.append(
            f"| {s.method} | {s.successes}/{s.runs} = {_g(100 * s.success_rate, '.1f')} % "
            f"[{100 * s.ci_low:.1f}, {100 * s.ci_high:.1f}]{other} | {s.limit_hits} | "
            f"{s.target_lost} | {s.max_iterations} | "
            f"{_g(s.iterations_median, '.0f')} ({_g(s.iterations_p90, '.0f')}) | "
            f"{_g(s.joint_speed_median)} ({_g(s.joint_speed_p95)}) | "
            f"{_g(s.cam_translation_median)} ({_g(s.cam_translation_p95)}) | "
            f"{_g(s.cam_rotation_median)} ({_g(s.cam_rotation_p95)}) | "
            f"{_g(s.discontinuity_median)} | {_g(s.min_margin_median, '.3f')} |"
        )
    return head + "\n".join(lines)


# --------------------------------------------------------------------------- result


@dataclass(frozen=True)
class CampaignResult:
    """The rows and per-method statistics of a campaign.

    Attributes:
        definition: The campaign definition.
        seed: The seed.
        samples: Number of samples N.
        methods: Methods, in table order.
        rows: One dict per (sample, method), sorted by sample then method (``samples.csv``
            columns).
        stats: :class:`MethodStats` per method.
        computed: Rows computed by this call (the others were reused from ``out``).
        out: Output directory, or None.
        figures: Paths of the written figures.
        markdown: Heading, the statistics table and notes (``campaign.md``).
    """

    definition: CampaignDefinition
    seed: int
    samples: int
    methods: tuple[str, ...]
    rows: tuple[dict[str, Any], ...]
    stats: dict[str, MethodStats]
    computed: int
    out: Path | None
    figures: tuple[Path, ...]
    markdown: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``campaign.json``); NaN becomes None."""

        def clean(v: Any) -> Any:
            return None if isinstance(v, float) and math.isnan(v) else v

        d = self.definition
        return {
            "campaign": d.name,
            "source": d.source,
            "scenario": d.scenario.source,
            "seed": self.seed,
            "samples": self.samples,
            "methods": list(self.methods),
            "fingerprint": d.fingerprint(self.seed),
            "success": "outcome == converged (no limit hit, target never lost)",
            "stats": {
                m: {k: clean(v) for k, v in s._asdict().items()} for m, s in self.stats.items()
            },
        }


def _heading(defn: CampaignDefinition, n: int, seed: int, rows: Sequence[Mapping[str, Any]]) -> str:
    st, tg = defn.start, defn.target
    data = defn.scenario.data
    rho = float(data["robot"].get("rho", 0.1))
    ctl, sim = data["control"], data.get("simulation", {})
    cap = int(sim.get("max_iterations", 1000))
    redraws = (
        sum(int(r["attempts"]) for r in rows if r["method"] == rows[0]["method"]) if rows else 0
    )

    def rng3(r: Sequence[Range]) -> str:
        return ", ".join(f"[{lo:g}, {hi:g}]" for lo, hi in r)

    if sim.get("stop_at_convergence", True):
        success = (
            f"Success = converged (‖e1‖ < {float(sim.get('tolerance', 1e-3)):g}) within {cap} "
            "iterations with no limit hit and the target never lost."
        )
    else:
        success = (
            f"Tracking task: every run lasts {cap} iterations; success = final ‖e1‖ < "
            f"{float(sim.get('tolerance', 1e-3)):g} with no limit hit and the target never "
            "lost (the iteration columns are then the run length)."
        )
    return (
        f"## Campaign {defn.name}\n\n"
        f"{defn.description}\n\n"
        f"Base scenario `{defn.scenario.name}` (λ = {float(ctl.get('lam', 0.5)):g} 1/s, "
        f"dt = {float(ctl.get('dt', 0.04)):g} s); N = {n} samples per method, seed {seed}. "
        f"Start: each joint in the outer band (margin in [{st.min_margin:g}, "
        f"{(1 + st.band_beyond) * rho:g}] of its range, thresholds at {rho:g}) with "
        f"probability {st.p_band:g}, at least {st.min_in_band} per start; target moved by "
        f"t ∈ {rng3(tg.translation)} m and turned by r ∈ {rng3(tg.rotation_deg)} deg; "
        f"{_errors_text(defn.errors)}{redraws} invalid starts re-drawn. {success}\n\n"
    )


def _errors_text(er: ErrorSpec) -> str:
    parts = []
    if er.noise_std:
        parts.append(f"feature noise std ∈ [{er.noise_std[0]:g}, {er.noise_std[1]:g}]")
    if er.depth_scale:
        parts.append(f"depth scale ∈ [{er.depth_scale[0]:g}, {er.depth_scale[1]:g}]")
    if er.hand_eye_translation or er.hand_eye_rotation_deg:
        parts.append(
            f"hand-eye error ±{er.hand_eye_translation:g} m, ±{er.hand_eye_rotation_deg:g} deg "
            "per axis"
        )
    return "Errors: " + "; ".join(parts) + ". " if parts else ""


def _figures(
    result_stats: Sequence[MethodStats],
    rows: Sequence[Mapping[str, Any]],
    out: Path,
    *,
    tracking: bool = False,
) -> tuple[Path, ...]:
    """Write ``success_rate.png`` and ``iterations.png`` (tracking: ``final_error.png``)."""
    try:
        from matplotlib.figure import Figure
    except ImportError:  # matplotlib is optional
        return ()
    names = [s.method for s in result_stats]
    x = np.arange(len(names))
    size = (max(6.0, 0.7 * len(names) + 2), 4.0)
    fig = Figure(figsize=size)
    ax = fig.add_subplot()
    rate = np.array([s.success_rate for s in result_stats]) * 100
    err = np.array(
        [
            [r - 100 * s.ci_low for r, s in zip(rate, result_stats)],
            [100 * s.ci_high - r for r, s in zip(rate, result_stats)],
        ]
    ).clip(min=0.0)  # rounding can make a bound cross p̂ by 1e-15 when p̂ is 0 or 1
    ax.bar(x, rate, yerr=err, capsize=3, color="tab:blue")
    ax.set_xticks(x, names, rotation=45, ha="right")
    ax.set_ylim(0, 105)
    ax.set_ylabel("success rate (%) with 95% Wilson CI")
    fig.tight_layout()
    p1 = out / "success_rate.png"
    fig.savefig(p1, dpi=120)
    fig = Figure(figsize=size)
    ax = fig.add_subplot()
    if tracking:  # every run lasts the same: show how well the runs that lasted tracked
        full = ("converged", "max_iterations")
        data = [
            [r["final_error"] for r in rows if r["method"] == m and r["outcome"] in full]
            for m in names
        ]
        ax.set_yscale("log")
        ax.set_ylabel("final ‖e1‖ (runs that lasted)")
        p2 = out / "final_error.png"
    else:
        data = [[r["iterations"] for r in rows if r["method"] == m and r["success"]] for m in names]
        ax.set_ylabel("iterations to converge (successes)")
        p2 = out / "iterations.png"
    ax.boxplot([d if d else [np.nan] for d in data], positions=x)
    ax.set_xticks(x, names, rotation=45, ha="right")
    fig.tight_layout()
    fig.savefig(p2, dpi=120)
    return p1, p2


# --------------------------------------------------------------------------- runner


def _executor_map(
    tasks: Iterator[_Task], workers: int, on_row: Callable[[dict[str, Any]], None]
) -> None:
    """Run tasks (in-process when ``workers == 1``), calling ``on_row`` as each finishes."""
    if workers == 1:
        for task in tasks:
            on_row(_run_task(task))
        return
    with ProcessPoolExecutor(max_workers=workers) as pool:
        pending: set[Future[dict[str, Any]]] = set()
        try:
            for task in tasks:
                pending.add(pool.submit(_run_task, task))
                # Keep a bounded queue so rows are stored while samples are still being drawn.
                while len(pending) >= 4 * workers:
                    done, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for fut in done:
                        on_row(fut.result())
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    on_row(fut.result())
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def run_campaign(
    campaign: str | Path | CampaignDefinition,
    *,
    methods: Sequence[str] | None = None,
    samples: int | None = None,
    seed: int = 0,
    workers: int | None = None,
    out: str | Path | None = None,
    progress: bool = True,
) -> CampaignResult:
    """Run a Monte Carlo campaign: every method on the same ``samples`` random variations.

    Args:
        campaign: A shipped campaign name, a definition file, or a :class:`CampaignDefinition`.
        methods: Methods to compare (default: the definition's list).
        samples: Number of samples N (default: the definition's).
        seed: Non-negative seed; sample ``i`` depends only on ``(definition, seed, i)``.
        workers: Processes (default: all cores); 1 runs in this process.
        out: Output directory for ``samples.csv`` (resumable), ``definition.json``,
            ``campaign.json``, ``campaign.md`` and figures; None writes nothing.
        progress: Show a progress bar on stderr (tqdm, if installed and stderr is a terminal).

    Returns:
        :class:`CampaignResult`.

    Raises:
        ScenarioError: bad definition, or no valid start for a sample.
        UnknownNameError: unknown method.
        ConfigurationError: bad ``samples``/``seed``/``workers``, or ``out`` holds another
            campaign.
    """
    from redservo.redundancy import METHODS

    defn = campaign if isinstance(campaign, CampaignDefinition) else load_campaign(campaign)
    names = tuple(methods) if methods is not None else defn.methods
    for m in names:
        if m not in METHODS:
            raise UnknownNameError(f"unknown method {m!r}; allowed: {', '.join(METHODS)}")
    if not names or len(set(names)) != len(names):
        raise ConfigurationError(f"methods must be a non-empty list without repeats, got {names}")
    n = defn.samples if samples is None else int(samples)
    if n < 1:
        raise ConfigurationError(f"samples must be at least 1, got {samples}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ConfigurationError(f"seed must be a non-negative integer, got {seed!r}")
    seed = int(seed)
    n_workers = (os.cpu_count() or 1) if workers is None else int(workers)
    if n_workers < 1:
        raise ConfigurationError(f"workers must be at least 1, got {workers}")
    out_dir = Path(out) if out is not None else None
    store = _Store(out_dir, defn, seed) if out_dir is not None else None
    done: dict[tuple[int, str], dict[str, Any]] = {
        key: row
        for key, row in (store.rows.items() if store else ())
        if key[0] < n and key[1] in names and row["outcome"] != "error"
    }
    todo = [(i, m) for i in range(n) for m in names if (i, m) not in done]
    joint_names = defn.nominal.joint_names

    def tasks() -> Iterator[_Task]:
        by_sample: dict[int, list[str]] = {}
        for i, m in todo:
            by_sample.setdefault(i, []).append(m)
        for i, ms in by_sample.items():
            s = draw_sample(defn, seed, i)
            params = _sample_columns(s, joint_names)
            for m in ms:
                opts = defn.method_options.get(m)
                yield _Task(
                    i,
                    m,
                    s.scenario.data,
                    s.scenario.source,
                    dict(opts) if opts is not None else None,
                    params,
                )

    bar = _bar(len(todo), defn.name, progress)
    errors: list[str] = []

    def on_row(row: dict[str, Any]) -> None:
        if store is not None:
            store.append(row)
            row = store.normalize(row)
        done[(row["sample"], row["method"])] = row
        if row["outcome"] == "error":
            errors.append(f"sample {row['sample']} {row['method']}: {row['error']}")
        bar(1)

    try:
        _executor_map(tasks(), min(n_workers, max(1, len(todo))), on_row)
    finally:
        bar(None)
    for msg in errors:
        print(f"redservo campaign: run failed with an exception: {msg}", file=sys.stderr)
    order = {m: k for k, m in enumerate(names)}
    rows = tuple(sorted(done.values(), key=lambda r: (r["sample"], order[r["method"]])))
    stats = {m: method_stats(m, [r for r in rows if r["method"] == m]) for m in names}
    markdown = _heading(defn, n, seed, rows) + stats_table(stats.values()) + "\n"
    figures: tuple[Path, ...] = ()
    result = CampaignResult(defn, seed, n, names, rows, stats, len(todo), out_dir, (), markdown)
    if out_dir is not None:
        tracking = not defn.scenario.data.get("simulation", {}).get("stop_at_convergence", True)
        figures = _figures(list(stats.values()), rows, out_dir, tracking=tracking)
        result = CampaignResult(
            defn, seed, n, names, rows, stats, len(todo), out_dir, figures, markdown
        )
        meta = {**result.to_dict(), "written": datetime.now(UTC).isoformat()}
        (out_dir / "campaign.json").write_text(json.dumps(meta, indent=2) + "\n")
        (out_dir / "campaign.md").write_text(markdown)
    return result


def _bar(total: int, desc: str, enabled: bool) -> Callable[[int | None], None]:
    """Return ``update(k)`` for a tqdm bar on stderr; ``update(None)`` closes it."""
    if not enabled or total == 0:
        return lambda _k: None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is an optional extra
        return lambda _k: None
    bar = tqdm(total=total, desc=desc, unit="run", file=sys.stderr, disable=None, leave=False)

    def update(k: int | None) -> None:
        if k is None:
            bar.close()
        else:
            bar.update(k)

    return update
