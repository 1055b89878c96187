"""Perturbed set-ups of an experiment, for the robustness sweep (``reproduce --robustness N``).

Each paper reports one run per experiment and our scenarios were found by searches that
kept the draws showing the paper's behaviour, so a verdict on the nominal set-up says
little about how much it depends on the exact numbers. A :class:`Perturbation` moves
every number a reader could not have known, within what a careful re-run of the
experiment could differ by:

* **target** (every object a feature observes): its origin moved by a uniform draw in
  ``±TARGET_SHIFT`` m per axis of the start camera frame, and the object turned about
  its own origin by a rotation vector drawn uniformly in ``±TARGET_TURN_DEG`` degrees per
  axis (start camera axes); other objects (the MC05 occluder) keep their world pose;
* **start**: each joint moved by a uniform draw in ``±START_TURN_DEG`` degrees (revolute)
  or ``±START_SHIFT`` m (prismatic), then clipped to the joint's range shrunk by
  ``START_CLIP`` of the range on each side;
* **period**: 40 or 80 ms with equal probability (``PERIODS``); λ (1/s) is kept and the
  iteration cap scaled so the run lasts as long as the nominal one;
* **depth error**: the controller's depth is ``depth_scale · Z``, ``depth_scale``
  log-uniform in ``DEPTH_SCALE`` (×0.5 to ×2);
* **pixel noise**: the features are measured in a rendered 640×480 image
  (:func:`redservo.reproduction.imaging.image_sensor`, true depth, then the depth error
  above) with Gaussian image noise of standard deviation uniform in ``NOISE_PX`` gray
  levels (0-255 scale);
* **blur**: the same image, blurred with a Gaussian of standard deviation uniform in
  ``BLUR_PX`` pixels;
* **focal length**: the same image drawn by a camera whose focal lengths are the assumed
  ones times a factor uniform in ``1 ± FOCAL_ERROR`` (an uncalibrated camera: the detector
  and the controller keep the assumed intrinsics).

The three image factors need OpenCV (``redservo[vision]``); :func:`image_sensor_available`
says whether it is installed, and the sweep says so when it is not.

A set-up perturbs one **factor** (:data:`FACTORS`) alone, every other number at its nominal
value, or ``"all"`` of them together. Every draw comes from
``numpy.random.SeedSequence(seed, spawn_key=(crc32(id), index, attempt))``, the factor not
included: set-up ``i`` of a single factor uses the very value that set-up ``i`` of ``"all"``
combines with the others, so a claim that fails in both can be traced to that factor. The
same seed gives the same set-ups on any machine, in any process, in any order. A set-up
whose scenario is invalid (the target outside the image at the start) is redrawn with the
next ``attempt``.
"""

from __future__ import annotations

import copy
import math
import zlib
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo.reproduction.imaging import Imaging, image_sensor
from redservo.scenario import Scenario, parse_scenario
from redservo.spatial import make_transform, matrix_to_rotvec, rotvec_to_matrix

if TYPE_CHECKING:
    from redservo.experiment.build import Experiment
    from redservo.sensors import Sensor

__all__ = [
    "BLUR_PX",
    "DEPTH_SCALE",
    "FACTORS",
    "FOCAL_ERROR",
    "IMAGE_FACTORS",
    "NOISE_PX",
    "PERIODS",
    "START_SHIFT",
    "START_TURN_DEG",
    "TARGET_SHIFT",
    "TARGET_TURN_DEG",
    "BoundPerturbation",
    "Perturbation",
    "draw_perturbation",
    "image_sensor_available",
]

TARGET_SHIFT = 0.02
"""Half-width (m) of the uniform shift of a target along each start-camera axis."""
TARGET_TURN_DEG = 2.0
"""Half-width (deg) of each component of the target's rotation vector."""
START_TURN_DEG = 2.0
"""Half-width (deg) of the shift of each revolute joint of the start."""
START_SHIFT = 0.01
"""Half-width (m) of the shift of each prismatic joint of the start."""
START_CLIP = 1e-3
"""A perturbed start stays this fraction of the range inside each real limit."""
PERIODS = (0.04, 0.08)
"""Control periods (s) drawn with equal probability."""
DEPTH_SCALE = (0.5, 2.0)
"""Range of the depth-error factor ``Ẑ/Z`` (log-uniform)."""
NOISE_PX = (0.0, 10.0)
"""Range (gray levels) of the image noise standard deviation (uniform)."""
BLUR_PX = (0.0, 2.0)
"""Range (pixels) of the standard deviation of the image blur (uniform)."""
FOCAL_ERROR = 0.05
"""Half-width of the relative error of the focal lengths (uniform: ±5 %)."""
FACTORS: tuple[str, ...] = (
    "target shift",
    "target turn",
    "start",
    "period",
    "depth",
    "noise",
    "blur",
    "focal",
    "all",
)
"""The factors a set-up perturbs alone, and ``"all"`` of them together (report order)."""
IMAGE_FACTORS: frozenset[str] = frozenset({"noise", "blur", "focal"})
"""Factors that need the image sensor (OpenCV)."""
MAX_JOINTS = 12
"""Start offsets drawn per set-up (the first n are used)."""


def image_sensor_available() -> bool:
    """Whether the image sensor (OpenCV, ``redservo[vision]``) can be used."""
    try:
        import cv2  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class Perturbation:
    """One perturbed set-up (module docstring); plain numbers, so it pickles and prints.

    Attributes:
        experiment: Id of the experiment it was drawn for.
        index: Set-up number (0-based).
        attempt: Redraw number (0 = first draw).
        target_shift: (3,) shift of the targets, start-camera axes (m).
        target_turn_deg: (3,) rotation vector of the targets about their origin (deg).
        start_offsets: (MAX_JOINTS,) joint offsets as fractions of the half-width in [-1, 1].
        period: Control period (s), or None to keep the scenario's.
        depth_scale: Depth-error factor ``Ẑ/Z``.
        noise_px: Image noise std (gray levels), or None for the ideal sensor (then
            ``blur_px`` and ``focal_scale`` are unused).
        seed: Seed of the image noise.
        factor: The factor perturbed (:data:`FACTORS`; ``"all"``: every one).
        blur_px: Image blur std (pixels).
        focal_scale: True focal lengths / assumed ones.
        start_scale: Multipliers of the start's half-widths (revolute, prismatic): 1 in the
            perturbed sweep, more for the unfiltered set-ups
            (:mod:`redservo.reproduction.unfiltered`).
    """

    experiment: str
    index: int
    attempt: int
    target_shift: tuple[float, float, float]
    target_turn_deg: tuple[float, float, float]
    start_offsets: tuple[float, ...]
    period: float | None
    depth_scale: float
    noise_px: float | None
    seed: int
    factor: str = "all"
    blur_px: float = 0.0
    focal_scale: float = 1.0
    start_scale: tuple[float, float] = (1.0, 1.0)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def describe(self) -> str:
        """One line: the period, depth factor and noise of the set-up."""
        parts = [f"dt = {self.period * 1e3:.0f} ms" if self.period else "nominal dt"]
        parts.append(f"depth ×{self.depth_scale:.2f}")
        if self.noise_px is None:
            parts.append("ideal sensor")
        else:
            parts.append(
                f"image σ = {self.noise_px:.1f}, blur {self.blur_px:.2f} px, "
                f"focal ×{self.focal_scale:.3f}"
            )
        return f"{self.factor}: " + ", ".join(parts)

    @property
    def imaging(self) -> Imaging | None:
        """The image the features are measured in, or None (ideal sensor)."""
        if self.noise_px is None:
            return None
        return Imaging(noise_px=self.noise_px, blur_px=self.blur_px, focal_scale=self.focal_scale)

    def bind(self, base: Scenario) -> BoundPerturbation:
        """Resolve the draw on the nominal scenario ``base`` (start, target poses)."""
        from redservo.experiment.build import build

        exp = build(base)
        lim, robot = exp.limits, exp.robot
        turn, slide = self.start_scale
        half = np.array(
            [
                slide * START_SHIFT if kind == "prismatic" else turn * math.radians(START_TURN_DEG)
                for kind in robot.joint_types
            ]
        )
        q0 = exp.q0 + half * np.asarray(self.start_offsets[: robot.n])
        pad = START_CLIP * lim.range
        q0 = np.clip(q0, lim.q_min + pad, lim.q_max - pad)
        bMc0 = robot.fkine(exp.q0)
        targets = {term.target for term in exp.task.terms}
        R = bMc0[:3, :3]
        dR = R @ rotvec_to_matrix(np.radians(self.target_turn_deg)) @ R.T
        dt = R @ np.asarray(self.target_shift)
        poses: dict[str, Any] = {}
        for name in exp.scene.names:
            wMo = exp.scene.wMo(name, 0.0)
            if name in targets:
                wMo = make_transform(dR @ wMo[:3, :3], wMo[:3, 3] + dt)
            poses[name] = wMo
        return BoundPerturbation(self, q0, poses, exp.options.dt)

    def sensor_for(self, exp: Experiment) -> Sensor | None:
        """The image sensor of this set-up for ``exp``'s camera, or None (ideal sensor)."""
        imaging = self.imaging
        if imaging is None:
            return None
        return image_sensor(exp.camera, imaging, seed=self.seed)


@dataclass(frozen=True)
class BoundPerturbation:
    """A :class:`Perturbation` resolved on a nominal scenario: applies it to any variant."""

    perturbation: Perturbation
    q0: np.ndarray
    poses: dict[str, np.ndarray]
    nominal_dt: float

    def apply(self, sc: Scenario) -> Scenario:
        """Return ``sc`` (a run's variant of the nominal scenario) on the perturbed set-up."""
        p = self.perturbation
        data = copy.deepcopy(sc.data)
        robot = data["robot"]
        for key in ("start_pose", "q_guess"):
            robot.pop(key, None)
        robot["q0"] = [float(v) for v in self.q0]
        for obj in data.get("objects", []):
            M = self.poses[obj["name"]]
            obj.pop("pose_in_camera", None)
            obj["pose"] = {
                "translation": [float(v) for v in M[:3, 3]],
                "rotvec": [float(v) for v in matrix_to_rotvec(M[:3, :3])],
            }
        control = data.setdefault("control", {})
        sim = data.setdefault("simulation", {})
        if p.period is not None:
            dt = float(control.get("dt", self.nominal_dt))
            control["dt"] = p.period
            if "max_iterations" in sim:
                sim["max_iterations"] = math.ceil(sim["max_iterations"] * dt / p.period)
        sim["depth_scale"] = float(sim.get("depth_scale", 1.0)) * p.depth_scale
        return parse_scenario(data, f"{sc.source} (perturbed set-up {p.index})")

    def sensor(self, exp: Experiment) -> Sensor | None:
        """The sensor of this set-up for ``exp`` (None: the ideal one)."""
        return self.perturbation.sensor_for(exp)


def draw_perturbation(
    experiment: str,
    index: int,
    *,
    seed: int = 0,
    attempt: int = 0,
    periods: tuple[float, ...] | None = PERIODS,
    pixel_noise: bool = True,
    factor: str = "all",
) -> Perturbation:
    """Draw set-up ``index`` of ``experiment`` (module docstring).

    Args:
        experiment: Experiment id (part of the seed).
        index: Set-up number.
        seed: Seed of the whole sweep.
        attempt: Redraw number.
        periods: Periods to draw from (s), or None to keep each scenario's period.
        pixel_noise: Measure the features in a rendered image (needs OpenCV); without it
            the image factors are not drawn (the sensor stays ideal).
        factor: The factor perturbed alone (:data:`FACTORS`), or ``"all"``.

    Raises:
        ValueError: an unknown ``factor``.
    """
    if factor not in FACTORS:
        raise ValueError(f"factor must be one of {', '.join(FACTORS)}, got {factor!r}")
    key = (zlib.crc32(experiment.encode()), int(index), int(attempt))
    rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=key))
    shift = rng.uniform(-TARGET_SHIFT, TARGET_SHIFT, 3)
    turn = rng.uniform(-TARGET_TURN_DEG, TARGET_TURN_DEG, 3)
    offsets = rng.uniform(-1.0, 1.0, MAX_JOINTS)
    period_i = int(rng.integers(0, len(PERIODS)))
    log_lo, log_hi = (math.log(v) for v in DEPTH_SCALE)
    depth = math.exp(rng.uniform(log_lo, log_hi))
    noise = float(rng.uniform(*NOISE_PX))
    noise_seed = int(rng.integers(0, 2**31 - 1))
    blur = float(rng.uniform(*BLUR_PX))
    focal = 1.0 + float(rng.uniform(-FOCAL_ERROR, FOCAL_ERROR))

    def on(name: str) -> bool:
        return factor in ("all", name)

    image = pixel_noise and (factor == "all" or factor in IMAGE_FACTORS)
    return Perturbation(
        experiment=experiment,
        index=int(index),
        attempt=int(attempt),
        target_shift=tuple(float(v) if on("target shift") else 0.0 for v in shift),  # type: ignore[arg-type]
        target_turn_deg=tuple(float(v) if on("target turn") else 0.0 for v in turn),  # type: ignore[arg-type]
        start_offsets=tuple(float(v) if on("start") else 0.0 for v in offsets),
        period=float(periods[period_i % len(periods)]) if periods and on("period") else None,
        depth_scale=float(depth) if on("depth") else 1.0,
        noise_px=(noise if on("noise") else 0.0) if image else None,
        seed=noise_seed,
        factor=factor,
        blur_px=blur if image and on("blur") else 0.0,
        focal_scale=focal if image and on("focal") else 1.0,
    )
