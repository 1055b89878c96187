"""Closed-loop simulation of a visual servo with a redundancy-based control law.

The loop, at every iteration k (time ``t = k dt``):

1. measure the features at the true camera pose ``bMc = fkine(q)``;
2. build ``e1`` and ``J1`` with the controller's model (depth estimate, hand-eye calibration);
3. call the law, a pure function of ``(J1, e1, q, limits, λ, dt, ...)``;
4. saturate ``q̇`` (optional), integrate ``q ← q + q̇ dt``.

The real joint limits are hard: when a step would cross one (by more than
``LIMIT_TOLERANCE``, the roundoff of a step commanded exactly onto a limit), the
run stops at that iteration with outcome ``joint_limit`` (the step is not
applied), as a real robot's safety stop would. Other outcomes: ``converged`` (``‖e1‖ <
tolerance``), ``max_iterations``, ``target_lost`` (a feature is invalid, behind
the camera, or leaves the image) and ``occluded``.

Units: seconds, metres, radians; ``λ`` in 1/s.
"""

from __future__ import annotations

import copy
import csv
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform
from redservo.camera import Camera
from redservo.errors import ConfigurationError, GeometryError
from redservo.features.point import point_interaction
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics, Law
from redservo.redundancy.costs import occlusion_force
from redservo.robots.base import Robot
from redservo.scene import PointSet, Scene, Sphere
from redservo.task import TaskState, VisualTask

__all__ = [
    "OUTCOMES",
    "Occlusion",
    "Outcome",
    "SimulationLog",
    "SimulationOptions",
    "SimulationResult",
    "simulate",
]

Outcome = Literal["converged", "joint_limit", "max_iterations", "target_lost", "occluded"]
OUTCOMES: tuple[Outcome, ...] = (
    "converged",
    "joint_limit",
    "max_iterations",
    "target_lost",
    "occluded",
)
Feedforward = Literal["none", "known", "estimated"]

LIMIT_TOLERANCE = 1e-9
"""A step ending within this distance (m or rad) beyond a real limit is floating-point
roundoff of a step commanded onto the limit (e.g. by ``qp`` or ``sns``): it lands on the
limit instead of counting as a crossing. The same tolerance as :meth:`JointLimits.check`."""


@dataclass(frozen=True, kw_only=True)
class Occlusion:
    """An occluding sphere that may hide a point-set target (MC05 experiment 2).

    The occluder's image is approximated by the disc of centre ``X0/Z0`` and
    radius ``r / sqrt(Z0² - r²)`` (normalized units). The target is *occluded*
    when one of its points falls inside that disc while the occluder is nearer
    the camera. With ``avoid=True`` the MC05 occlusion force (eq. 31), computed
    from the occluder's image point closest to the nearest target point, is
    passed to the law as its ``secondary`` command, scaled by ``gain``.

    Attributes:
        occluder: Scene name of the occluding :class:`~redservo.scene.Sphere`.
        target: Scene name of the observed :class:`~redservo.scene.PointSet`.
        beta: ``β`` of the cost ``V = exp(-β d²)`` (MC05 eq. 30), 1/(normalized units)².
        gain: Scale of the artificial force (joint velocity per unit force).
        avoid: Feed the force to the law as ``secondary``.
    """

    occluder: str
    target: str
    beta: float = 50.0
    gain: float = 1.0
    avoid: bool = True


@dataclass(frozen=True, kw_only=True)
class SimulationOptions:
    """Options of :func:`simulate`.

    Attributes:
        lam: Gain λ (1/s).
        dt: Control period (s).
        max_iterations: Iteration cap.
        tolerance: Convergence threshold on ``‖e1‖`` (task units).
        rho: Band width of the joint-limit thresholds (CM01 eq. 3).
        qdot_max: Joint-velocity saturation (scalar or (n,), rad/s or m/s):
            the whole command is scaled down uniformly so that every joint
            respects it (direction kept). None = no saturation.
        noise_std: Standard deviation of additive noise on the features (feature units).
        seed: Seed of the noise generator.
        depth_scale: The controller's depth estimate is ``Ẑ = depth_scale · Z``.
        eMc_model: 4x4 hand-eye transform the *controller* believes in (None =
            the true one); models a calibration error.
        feedforward: ``"none"``, ``"known"`` (∂e1/∂t from the target's known
            motion) or ``"estimated"`` (``(e1_k - e1_{k-1})/dt - J1 q̇_{k-1}``).
        image_margin_px: A feature point closer than this to the image border counts as lost.
        check_image: Stop with ``target_lost`` when an object leaves the image.
        occlusion: Occlusion set-up, or None.
        stop_at_convergence: Stop as soon as ``‖e1‖ < tolerance``. Set False for
            tracking tasks: the run then lasts ``max_iterations`` and its outcome is
            ``converged`` when the final error is below the tolerance.
    """

    lam: float = 0.5
    dt: float = 0.04
    max_iterations: int = 1000
    tolerance: float = 1e-3
    rho: float = 0.1
    qdot_max: float | tuple[float, ...] | None = None
    noise_std: float = 0.0
    seed: int = 0
    depth_scale: float = 1.0
    eMc_model: FloatArray | None = None
    feedforward: Feedforward = "none"
    image_margin_px: float = 0.0
    check_image: bool = True
    occlusion: Occlusion | None = None
    stop_at_convergence: bool = True

    def __post_init__(self) -> None:
        checks: list[tuple[str, bool, str]] = [
            ("lam", self.lam > 0, "a positive gain (1/s)"),
            ("dt", self.dt > 0, "a positive period (s)"),
            ("max_iterations", self.max_iterations >= 1, "at least 1"),
            ("tolerance", self.tolerance > 0, "positive"),
            ("rho", 0 < self.rho < 0.5, "in (0, 0.5)"),
            ("noise_std", self.noise_std >= 0, "non-negative"),
            ("depth_scale", self.depth_scale > 0, "positive"),
            ("image_margin_px", self.image_margin_px >= 0, "non-negative"),
        ]
        for name, ok, allowed in checks:
            if not ok:
                raise ConfigurationError(f"{name} must be {allowed}, got {getattr(self, name)!r}")
        if self.qdot_max is not None and np.any(np.asarray(self.qdot_max, dtype=float) <= 0):
            raise ConfigurationError(f"qdot_max must be positive, got {self.qdot_max!r}")
        if self.feedforward not in ("none", "known", "estimated"):
            raise ConfigurationError(
                f"feedforward must be 'none', 'known' or 'estimated', got {self.feedforward!r}"
            )
        if self.eMc_model is not None:
            object.__setattr__(self, "eMc_model", as_transform(self.eMc_model, "eMc_model"))


@dataclass
class SimulationLog:
    """Per-iteration log of a run; row i is iteration i. Arrays are (N, ·)."""

    t: FloatArray
    q: FloatArray
    qdot: FloatArray
    camera_twist: FloatArray
    s: FloatArray
    e: FloatArray
    e1: FloatArray
    error_norm: FloatArray
    q_normalized: FloatArray
    alpha: FloatArray
    projector_rank: FloatArray
    task_rank: FloatArray
    levels: FloatArray
    overconstrained: FloatArray
    constrained: FloatArray
    gamma: FloatArray
    scale: FloatArray
    diagnostics: list[Diagnostics] = field(default_factory=list, repr=False)
    joint_names: tuple[str, ...] = ()
    feature_names: tuple[str, ...] = ()

    _ARRAYS = (
        "t",
        "q",
        "qdot",
        "camera_twist",
        "s",
        "e",
        "e1",
        "error_norm",
        "q_normalized",
        "alpha",
        "projector_rank",
        "task_rank",
        "levels",
        "overconstrained",
        "constrained",
        "gamma",
        "scale",
    )

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def arrays(self) -> dict[str, FloatArray]:
        """Return the logged arrays by name."""
        return {name: getattr(self, name) for name in self._ARRAYS}

    def save_npz(self, path: str | Path) -> None:
        """Save every array to a compressed ``.npz`` (plus joint and feature names)."""
        data: dict[str, Any] = {
            **self.arrays(),
            "joint_names": np.array(self.joint_names),
            "feature_names": np.array(self.feature_names),
        }
        np.savez_compressed(path, **data)

    def save_csv(self, path: str | Path) -> None:
        """Save one row per iteration; vector columns are split as ``name[i]``."""
        cols: list[str] = []
        blocks: list[FloatArray] = []
        for name, arr in self.arrays().items():
            a = arr.reshape(len(self), -1)
            if a.shape[1] == 1:
                cols.append(name)
            else:
                cols.extend(f"{name}[{i}]" for i in range(a.shape[1]))
            blocks.append(a.astype(float))
        table = np.hstack(blocks) if blocks else np.zeros((0, 0))
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(cols)
            for row in table:
                w.writerow([f"{v:.10g}" for v in row])


@dataclass
class SimulationResult:
    """The outcome, summary and log of one run."""

    outcome: Outcome
    summary: dict[str, Any]
    log: SimulationLog

    def save(self, directory: str | Path, *, extra: dict[str, Any] | None = None) -> Path:
        """Write ``summary.json``, ``log.npz`` and ``log.csv`` into ``directory``."""
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        summary = {**self.summary, **(extra or {})}
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        self.log.save_npz(out / "log.npz")
        self.log.save_csv(out / "log.csv")
        return out


def _saturate(qdot: FloatArray, qdot_max: FloatArray | None) -> FloatArray:
    if qdot_max is None:
        return qdot
    ratio = float(np.max(np.abs(qdot) / qdot_max))
    return qdot / ratio if ratio > 1.0 else qdot


def _visible_points(scene: Scene, name: str, bMc: FloatArray, t: float) -> FloatArray:
    """Camera-frame points whose image must stay in view for object ``name``."""
    obj = scene.object(name)
    cMo = scene.cMo(name, bMc, t)
    if isinstance(obj, PointSet):
        pts = np.asarray(obj.points, dtype=float)
    elif hasattr(obj, "center"):
        pts = np.asarray(obj.center, dtype=float)[None, :]
    elif hasattr(obj, "point"):
        pts = np.asarray(obj.point, dtype=float)[None, :]
    else:  # pragma: no cover - every scene object has a reference point
        pts = np.zeros((1, 3))
    return np.asarray(pts @ cMo[:3, :3].T + cMo[:3, 3])


def _occlusion_state(
    scene: Scene, occ: Occlusion, bMc: FloatArray, t: float
) -> tuple[bool, FloatArray | None, FloatArray | None, float]:
    """Return (occluded, occluder image point p_a, nearest target point, occluder depth)."""
    sph = scene.object(occ.occluder)
    if not isinstance(sph, Sphere):
        raise ConfigurationError(f"occluder {occ.occluder!r} must be a Sphere")
    cMo = scene.cMo(occ.occluder, bMc, t)
    X0 = cMo[:3, :3] @ np.asarray(sph.center, dtype=float) + cMo[:3, 3]
    r = float(sph.radius)
    if X0[2] <= r:  # behind or around the camera plane: cannot occlude
        return False, None, None, 0.0
    c = X0[:2] / X0[2]
    radius = r / np.sqrt(X0[2] ** 2 - r**2)
    P = _visible_points(scene, occ.target, bMc, t)
    xy = P[:, :2] / P[:, 2:3]
    dist = np.linalg.norm(xy - c, axis=1)
    j = int(np.argmin(dist))
    occluded = bool(np.any((dist < radius) & (P[:, 2] > X0[2] - r)))
    direction = xy[j] - c
    nd = float(np.linalg.norm(direction))
    p_a = c + (radius * direction / nd if nd > 1e-12 else np.array([radius, 0.0]))
    return occluded, p_a, xy[j], float(X0[2])


def simulate(
    robot: Robot,
    scene: Scene,
    task: VisualTask,
    law: Law,
    q0: ArrayLike,
    *,
    options: SimulationOptions | None = None,
    camera: Camera | None = None,
    limits: JointLimits | None = None,
    secondary: Callable[[TaskState, FloatArray, float], FloatArray | None] | None = None,
    progress: Callable[[int], None] | None = None,
) -> SimulationResult:
    """Run the closed loop from ``q0``; see the module docstring.

    Args:
        robot: The true robot (its ``eMc`` is the true hand-eye transform).
        scene: Objects and their motion.
        task: The visual task.
        law: A control law (:func:`redservo.make_law`).
        q0: (n,) start configuration, within the limits.
        options: :class:`SimulationOptions` (defaults if None).
        camera: Image size for the ``target_lost`` check (default :class:`Camera`).
        limits: Joint limits (default: the robot's, with ``options.rho``).
        secondary: Optional ``f(state, q, t) -> (n,)`` extra joint command passed to the law.
        progress: Optional callback called with the iteration index.

    Returns:
        :class:`SimulationResult` with the outcome, the summary dict and the log.

    Raises:
        JointLimitError: ``q0`` is outside the limits.
        GeometryError: the task is invalid at ``q0`` (e.g. target behind the camera).
    """
    opt = options or SimulationOptions()
    cam = camera or Camera()
    lim = limits or robot.limits(opt.rho)
    q = lim.check(q0, "q0").copy()
    n = robot.n
    model = robot
    if opt.eMc_model is not None:
        model = copy.copy(robot)
        model.eMc = opt.eMc_model
    qdot_max = None
    if opt.qdot_max is not None:
        qdot_max = np.broadcast_to(np.asarray(opt.qdot_max, dtype=float), (n,)).copy()
    rng = np.random.default_rng(opt.seed)
    k, m = task.k, task.m
    N = opt.max_iterations
    buf = {
        "t": np.zeros(N),
        "q": np.zeros((N, n)),
        "qdot": np.zeros((N, n)),
        "camera_twist": np.zeros((N, 6)),
        "s": np.zeros((N, k)),
        "e": np.zeros((N, k)),
        "e1": np.zeros((N, m)),
        "error_norm": np.zeros(N),
        "q_normalized": np.zeros((N, n)),
        "alpha": np.full(N, np.nan),
        "projector_rank": np.zeros(N),
        "task_rank": np.zeros(N),
        "levels": np.zeros(N),
        "overconstrained": np.zeros(N),
        "constrained": np.zeros((N, n)),
        "gamma": np.zeros((N, n)),
        "scale": np.full(N, np.nan),
    }
    diags: list[Diagnostics] = []
    outcome: Outcome = "max_iterations"
    limit_hit: dict[str, int] | None = None
    prev_e1: FloatArray | None = None
    prev_J1qdot: FloatArray | None = None
    targets = sorted({term.target for term in task.terms})
    rows = 0
    for it in range(N):
        t = it * opt.dt
        bMc, J_true = robot.kinematics(q, check_limits=False)
        J = J_true if model is robot else model.jacobian(q, check_limits=False)
        noise = rng.normal(0.0, opt.noise_std, k) if opt.noise_std > 0 else None
        try:
            state = task.evaluate(scene, bMc, J, t, depth_scale=opt.depth_scale, noise=noise)
            if opt.check_image and not all(
                _in_image(cam, _visible_points(scene, name, bMc, t), opt.image_margin_px)
                for name in targets
            ):
                raise GeometryError("an object left the image")
        except GeometryError:
            outcome = "target_lost"
            break
        sec = secondary(state, q, t) if secondary is not None else None
        if opt.occlusion is not None:
            occluded, p_a, p_t, z_occ = _occlusion_state(scene, opt.occlusion, bMc, t)
            if occluded:
                outcome = "occluded"
                break
            if opt.occlusion.avoid and p_a is not None and p_t is not None:
                H = point_interaction(float(p_a[0]), float(p_a[1]), 1.0 / z_occ) @ J
                f = occlusion_force(p_a, p_t, H, beta=opt.occlusion.beta).force
                f = opt.occlusion.gain * f
                sec = f if sec is None else sec + f
        err = float(np.linalg.norm(state.e1))
        de1_dt = None
        if opt.feedforward == "known":
            de1_dt = _known_feedforward(task, scene, bMc, t, opt.dt)
        elif opt.feedforward == "estimated" and prev_e1 is not None and prev_J1qdot is not None:
            de1_dt = (state.e1 - prev_e1) / opt.dt - prev_J1qdot
        res = law(
            J1=state.J1,
            e1=state.e1,
            q=q,
            limits=lim,
            lam=opt.lam,
            dt=opt.dt,
            de1_dt=de1_dt,
            secondary=sec,
        )
        qdot = _saturate(res.qdot, qdot_max)
        d = res.diagnostics
        _record(buf, it, t, q, qdot, J_true @ qdot, state, err, lim, d)
        diags.append(d)
        rows = it + 1
        if err < opt.tolerance and (opt.stop_at_convergence or it == N - 1):
            outcome = "converged"
            break
        q_next = q + qdot * opt.dt
        crossed = np.flatnonzero(
            (q_next < lim.q_min - LIMIT_TOLERANCE) | (q_next > lim.q_max + LIMIT_TOLERANCE)
        )
        if crossed.size:
            outcome = "joint_limit"
            limit_hit = {"axis": int(crossed[0]), "iteration": it}
            break
        prev_e1, prev_J1qdot = state.e1, state.J1 @ qdot
        # A step commanded exactly onto a limit lands on it (roundoff is not a crossing).
        q = np.clip(q_next, lim.q_min, lim.q_max)
        if progress is not None:
            progress(it)
    log = SimulationLog(
        **{name: arr[:rows].copy() for name, arr in buf.items()},
        diagnostics=diags,
        joint_names=robot.joint_names,
        feature_names=task.names,
    )
    return SimulationResult(outcome, summarize(log, outcome, lim, limit_hit), log)


def _in_image(cam: Camera, P: FloatArray, margin_px: float) -> bool:
    if np.any(P[:, 2] <= 1e-9):
        return False
    xy = P[:, :2] / P[:, 2:3]
    return bool(np.all(cam.in_image(xy, margin_px=margin_px)))


def _known_feedforward(
    task: VisualTask, scene: Scene, bMc: FloatArray, t: float, dt: float
) -> FloatArray:
    """``∂e1/∂t`` from the target's known motion: central difference with the camera frozen."""
    h = 0.5 * dt
    s_p, _ = task.measure(scene, bMc, t + h)
    s_m, _ = task.measure(scene, bMc, max(t - h, 0.0))
    ds = task.error(s_p) - task.error(s_m)
    ds /= h + min(h, t)
    return ds if task.C is None else task.C @ ds


def _record(
    buf: dict[str, FloatArray],
    i: int,
    t: float,
    q: FloatArray,
    qdot: FloatArray,
    twist: FloatArray,
    state: TaskState,
    err: float,
    lim: JointLimits,
    d: Diagnostics,
) -> None:
    buf["t"][i] = t
    buf["q"][i] = q
    buf["qdot"][i] = qdot
    buf["camera_twist"][i] = twist
    buf["s"][i] = state.s
    buf["e"][i] = state.e
    buf["e1"][i] = state.e1
    buf["error_norm"][i] = err
    buf["q_normalized"][i] = lim.normalized(q)
    if d.alpha is not None:
        buf["alpha"][i] = d.alpha
    buf["projector_rank"][i] = d.projector_rank
    buf["task_rank"][i] = d.task_rank
    buf["levels"][i] = d.iterations
    buf["overconstrained"][i] = float(d.overconstrained)
    for level in d.critical:
        buf["constrained"][i, list(level)] = 1.0
    if d.gamma is not None:
        buf["gamma"][i] = d.gamma
    if d.scale is not None:
        buf["scale"][i] = d.scale


def summarize(
    log: SimulationLog,
    outcome: Outcome,
    limits: JointLimits,
    limit_hit: dict[str, int] | None,
) -> dict[str, Any]:
    """Return the run summary (see the project README for the fields and units)."""
    n = limits.n
    if len(log):
        margin = float(np.min(limits.margin(log.q)))
        max_joint = np.max(np.abs(log.qdot), axis=0)
        tw = log.camera_twist
        max_cam = {
            "translation": float(np.max(np.linalg.norm(tw[:, :3], axis=1))),
            "rotation": float(np.max(np.linalg.norm(tw[:, 3:], axis=1))),
        }
        jumps = np.linalg.norm(np.diff(log.qdot, axis=0), axis=1)
        disc = float(np.max(jumps)) if jumps.size else 0.0
        final = float(log.error_norm[-1])
    else:
        margin, max_joint, disc, final = float("nan"), np.zeros(n), 0.0, float("nan")
        max_cam = {"translation": 0.0, "rotation": 0.0}
    return {
        "outcome": outcome,
        "iterations": len(log),
        "final_error_norm": final,
        "limit_hit": limit_hit,
        "min_margin": margin,
        "max_joint_speed": [float(v) for v in max_joint],
        "max_camera_speed": max_cam,
        "discontinuity": disc,
    }
