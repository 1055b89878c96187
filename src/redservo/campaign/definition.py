"""The campaign definition: TOML format, parsing and validation.

The format is documented in ``docs/campaigns.md`` (its reference is generated from
:class:`redservo.schema.campaign.CampaignSpec`) and in the module docstring of
:mod:`redservo.campaign`.
"""

from __future__ import annotations

import copy
import hashlib
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Literal, NamedTuple

from redservo._validation import FloatArray
from redservo.errors import ScenarioError
from redservo.limits import JointLimits
from redservo.scenario import (
    Scenario,
    load_scenario,
    locate,
    parse_scenario,
    read_toml,
    shipped_descriptions,
)
from redservo.schema.base import unknown_name
from redservo.schema.campaign import CampaignSpec
from redservo.schema.explain import validate

FORMAT_VERSION = 4
"""Version of the sampling algorithm and the row format, part of the fingerprint (4: each
row of ``samples.csv`` sealed with its check, :mod:`redservo.campaign.rowfile`)."""

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


def fingerprint_of(definition: Mapping[str, Any], scenario: Mapping[str, Any], seed: int) -> str:
    """SHA-256 (hex) of a campaign's definition table (without ``methods``, ``samples`` and
    ``description``), its base scenario, the seed and :data:`FORMAT_VERSION`: what
    :meth:`CampaignDefinition.fingerprint` returns, and what ``definition.json``'s own
    content must give (an edited ``definition.json`` no longer does)."""
    table = {k: v for k, v in definition.items() if k not in ("methods", "samples", "description")}
    blob = json.dumps(
        {"format": FORMAT_VERSION, "seed": int(seed), "definition": table, "scenario": scenario},
        sort_keys=True,
        separators=(",", ":"),
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()


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
        return fingerprint_of(self.data, self.scenario.data, seed)

    @cached_property
    def nominal(self) -> _Nominal:
        """The base scenario evaluated at its own start (cached)."""
        from redservo.experiment.build import build

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
        ScenarioError: missing file, not UTF-8, invalid TOML, or a key fails validation (the
            message names the file and the key).
    """
    file, source, base_dir = locate(name_or_path, "scenarios/campaigns", "campaign")
    return parse_campaign(read_toml(file, source), source, base_dir=base_dir)


def _base_scenario(spec: CampaignSpec, src: str, base_dir: Path | None) -> Scenario:
    """The base scenario with the campaign's overrides applied."""
    ref = spec.scenario
    ref_path = Path(ref)
    if ref.endswith(".toml") and not ref_path.is_absolute() and base_dir is not None:
        ref_path = base_dir / ref_path
    try:
        base = load_scenario(ref_path if ref.endswith(".toml") else ref)
    except ScenarioError as exc:
        raise ScenarioError(f"{src}: key 'scenario': {exc}", argument="scenario") from None
    if not spec.overrides:
        return base
    merged = parse_scenario(  # errors name the campaign file and overrides.KEY
        _merge(base.data, spec.overrides),
        src,
        base_dir=Path(base.source).parent if base.source.endswith(".toml") else None,
        key_prefix="overrides.",
    )
    out = Scenario(merged.data, f"{base.source} (overrides from {src})")
    out._spec = merged.spec
    return out


def parse_campaign(
    data: Mapping[str, Any], source: str = "<campaign>", *, base_dir: Path | None = None
) -> CampaignDefinition:
    """Validate a campaign table and return the definition.

    The schema (:class:`redservo.schema.campaign.CampaignSpec`) checks every key; then the
    base scenario is loaded (with the overrides) and what depends on it is checked: the
    start band against its ``rho``, the joint names against its robot.

    Args:
        data: The TOML table.
        source: Where it came from (used in error messages).
        base_dir: Directory against which a relative ``scenario`` path is resolved
            (None: the current directory).

    Raises:
        ScenarioError: naming ``source`` and the offending key.
    """
    from redservo.redundancy import METHODS

    table = copy.deepcopy(dict(data))
    spec: CampaignSpec = validate(CampaignSpec, table, source)
    base = _base_scenario(spec, source, base_dir)
    st, tg, er = spec.start, spec.target, spec.errors
    start = StartSpec(
        p_band=st.p_band,
        band_beyond=st.band_beyond,
        min_margin=st.min_margin,
        min_in_band=st.min_in_band,
        joints=None if st.joints is None else tuple(st.joints),
    )
    _check_start(start, base, source)
    t3, r3 = tg.translation, tg.rotation_deg
    return CampaignDefinition(
        name=str(spec.name or Path(source).stem),
        description=spec.description,
        source=source,
        scenario=base,
        methods=tuple(spec.methods if spec.methods is not None else METHODS),
        method_options={m: dict(o) for m, o in spec.method_options.items()},
        samples=spec.samples,
        start=start,
        target=TargetSpec(
            translation=(t3[0], t3[1], t3[2]),
            rotation_deg=(r3[0], r3[1], r3[2]),
            image_margin_px=tg.image_margin_px,
            motion_frame=tg.motion_frame,
        ),
        errors=ErrorSpec(
            noise_std=er.noise_std,
            depth_scale=er.depth_scale,
            hand_eye_translation=er.hand_eye_translation,
            hand_eye_rotation_deg=er.hand_eye_rotation_deg,
        ),
        max_attempts=spec.max_attempts,
        data=table,
    )


def _check_start(spec: StartSpec, base: Scenario, src: str) -> None:
    """What ``[start]`` must satisfy given the base scenario's ``rho`` and joints."""
    from redservo.experiment.build import build_robot

    rho = base.spec.robot.rho
    names = build_robot(base).joint_names
    outer = (1.0 + spec.band_beyond) * rho
    if outer >= 0.5:
        raise ScenarioError(
            f"{src}: key 'start.band_beyond': must be >= 0 with (1 + band_beyond) rho < 0.5 "
            f"(rho = {rho} from the scenario), got {spec.band_beyond}",
            argument="start.band_beyond",
        )
    if not spec.min_margin < outer:
        raise ScenarioError(
            f"{src}: key 'start.min_margin': must be in [0, (1 + band_beyond) rho = {outer:.4g}) "
            f"(fraction of the range), got {spec.min_margin}",
            argument="start.min_margin",
        )
    if spec.joints is not None:
        for i, j in enumerate(spec.joints):
            if j not in names:
                raise ScenarioError(
                    f"{src}: key 'start.joints[{i}]': {unknown_name('joint', j, names)}",
                    argument=f"start.joints[{i}]",
                )
    n_eligible = len(names) if spec.joints is None else len(set(spec.joints))
    if spec.min_in_band > n_eligible:
        raise ScenarioError(
            f"{src}: key 'start.min_in_band': must be in [0, {n_eligible}] (the eligible "
            f"joints), got {spec.min_in_band}",
            argument="start.min_in_band",
        )
