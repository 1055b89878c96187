"""Random variations of a campaign's base scenario: start configurations and samples.

See the module docstring of :mod:`redservo.campaign` ("Start configurations", "Target
placement", "Invalid starts").
"""

from __future__ import annotations

import pickle
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.campaign.definition import CampaignDefinition, Range
from redservo.errors import ConfigurationError, ScenarioError
from redservo.limits import JointLimits
from redservo.scenario import Scenario
from redservo.spatial import inverse, make_transform, matrix_to_rotvec

BoolArray = NDArray[np.bool_]


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
    data = pickle.loads(pickle.dumps(defn.scenario.data, pickle.HIGHEST_PROTOCOL))  # a deep copy
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
    from redservo.campaign.start import start_check

    return start_check(defn, sc)[0]


def draw_sample(defn: CampaignDefinition, seed: int, index: int) -> Sample:
    """Draw the valid sample ``index`` of a campaign, deterministically from ``seed``.

    Attempt ``a`` uses ``SeedSequence(seed, spawn_key=(index, a))``; invalid starts are
    re-drawn (module docstring, "Invalid starts").

    Raises:
        ScenarioError: no valid start in ``defn.max_attempts`` draws.
    """
    return draw_built(defn, seed, index)[0]


def draw_built(defn: CampaignDefinition, seed: int, index: int) -> tuple[Sample, Any]:
    """:func:`draw_sample` and the sample's experiment, built once by the start check
    (:mod:`redservo.campaign.start`), for the runs of the sample."""
    from redservo.campaign.start import start_check

    last = ""
    for attempt in range(defn.max_attempts):
        sample = _draw(defn, seed, index, attempt)
        problem, exp = start_check(defn, sample.scenario)
        if problem is None:
            return sample, exp
        last = problem
    raise ScenarioError(
        f"{defn.source}: key 'target': sample {index}: no valid start in {defn.max_attempts} "
        f"draws (last: {last}); narrow the [target] ranges or raise max_attempts"
    )
