"""The compiled fast path of a campaign run, and when it applies (docs/scaling.md).

:func:`fast_summary` runs one (sample, method) of a campaign with the compiled closed loop
of :mod:`redservo.campaign.loop_kernel` and returns the same
:class:`~redservo.simulation.RunSummary` as ``Experiment.run`` (every row of
``samples.csv`` bit for bit: tests/test_campaign_fast.py), or None when the set-up is not
covered; the caller then runs the object path. :func:`fast_reason` says why a set-up is
not covered:

* the kernels run uncompiled (numba not installed, or switched off:
  :func:`redservo.bench.kernel_mode.uncompiled_reason`): the loop would run as plain Python,
  slower than the object path;
* a method without a compiled step (``predictive``, a user-registered law) or with
  ``scaling = "secondary-first"``;
* an image sensor, an actuator model, an occlusion objective, feature noise, a hand-eye
  calibration error, the estimated feed-forward (the known one is covered), an adaptive
  gain, a camera-motion limit (the Controller applies it: the object path);
* obstacles the loop does not measure (:mod:`redservo.campaign.loop_avoid`; ``qp`` and
  ``sns`` avoid on the loop with their velocity-damper rows, solved in the loop by the
  kernels the laws call: :mod:`redservo.kernels.loop_rows`);
* a robot other than the Afma6, a DH chain or a :class:`~redservo.robots.chain.ChainRobot`
  (URDF robots), features other than image points and moments, a depth option other
  than ``"current"``, a target that is not a point set, static or on waypoints
  (:mod:`redservo.campaign.looppack`).

A covered run whose law would raise (non-finite ``J1``, inconsistent ``sns`` bounds) is
also handed back to the object path, which records the exception as the object path does.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from redservo.campaign.loop_avoid import collision_fields, collision_pack, collision_reason
from redservo.campaign.loop_handback import flag_bits
from redservo.campaign.loop_summary import loop_summary
from redservo.campaign.looplaw import cached_law_args, method_law
from redservo.campaign.looplaw import law_args as _law_args
from redservo.campaign.looppack import (
    robot_args,
    robot_reason,
    scene_args,
    scene_reason,
    task_args,
)
from redservo.errors import ConfigurationError, RedservoError
from redservo.experiment.build import Experiment
from redservo.records import Outcome, RunSummary, SimulationLog, summarize
from redservo.redundancy import Law, make_law
from redservo.redundancy.flags import FLAGS
from redservo.redundancy.gain import AdaptiveGain

__all__ = [
    "campaign_law",
    "experiment_reason",
    "fast_reason",
    "fast_run",
    "fast_summary",
    "law_reason",
]

_OUTCOMES: tuple[Outcome, ...] = (
    "max_iterations",
    "converged",
    "joint_limit",
    "target_lost",
    "max_iterations",  # NEED_SOLVE: never an outcome
    "collision",
)
"""Outcome names by the kernel's codes (:mod:`redservo.campaign.loop_kernel`)."""
_flag_bits = flag_bits
"""The loop's bit mask of a law's typed events (:func:`~redservo.campaign.loop_handback.flag_bits`)."""
_BUFFERS = threading.local()
"""Per-thread reuse: the log buffers and the packed arguments of the last experiment (a
sample's methods run one after the other on it); the laws: :mod:`redservo.campaign.looplaw`."""


def campaign_law(exp: Experiment, method: str, law_options: Mapping[str, Any] | None) -> Law:
    """The law ``Experiment.run(method=..., law_options=...)`` builds: the scenario's safety
    options, then ``law_options`` (or the scenario's own options for its own method)."""
    ctl = exp.scenario.spec.control
    if law_options is not None:
        opts = dict(law_options)
    else:
        opts = dict(ctl.options) if method == ctl.method else {}
    safety = {"shield": ctl.shield, "robust": ctl.robust, "scaling": ctl.scaling}
    return make_law(method, **{**safety, **opts})


def _compiled() -> bool:
    from redservo.kernels import compiled

    return compiled()


def law_reason(law: Law) -> str | None:
    """Why the compiled loop cannot run ``law`` (None: it can)."""
    from redservo.kernels.step import LAW_IDS
    from redservo.redundancy.qp import BoundedLeastSquares

    if not _compiled():
        from redservo.bench.kernel_mode import uncompiled_reason

        return uncompiled_reason()
    from redservo.redundancy.declare import kernel_class

    known = law.name in LAW_IDS or type(law) is BoundedLeastSquares
    if not known or (type(law) is not BoundedLeastSquares and kernel_class(type(law)) is None):
        return f"method {law.name!r} has no compiled step"
    if law.scaling != "uniform":
        return "scaling = 'secondary-first'"
    return None


def experiment_reason(exp: Experiment) -> str | None:
    """Why the compiled loop cannot run ``exp`` (None: it can); module docstring."""
    opt = exp.options
    checks: tuple[tuple[bool, str], ...] = (
        (exp.sensor is not None, "image sensor"),
        (exp.actuator is not None, "actuator model"),
        (opt.occlusion is not None, "occlusion objective"),
        (opt.noise_std > 0, "feature noise"),
        (opt.eMc_model is not None, "hand-eye calibration error"),
        (opt.feedforward == "estimated", "feed-forward 'estimated'"),
        (isinstance(opt.lam, AdaptiveGain), "adaptive gain"),
        (opt.image_motion is not None, "camera-motion limit"),
    )
    for failed, reason in checks:
        if failed:
            return reason
    return robot_reason(exp) or scene_reason(exp)


def fast_reason(exp: Experiment, law: Law) -> str | None:
    """Why the compiled loop cannot run ``law`` on ``exp`` (None: it can); module docstring."""
    return law_reason(law) or experiment_reason(exp) or collision_reason(exp, law)


def _buffers(N: int, n: int) -> tuple[Any, ...]:
    """Per-thread log buffers ``(Q, QD, TW, EN, FL)``, reused from run to run (the summary
    copies what it keeps)."""
    key = (N, n)
    bufs = getattr(_BUFFERS, "bufs", None)
    if bufs is None or bufs[0] != key:
        logs = (
            np.empty((N, n)),
            np.empty((N, n)),
            np.empty((N, 6)),
            np.empty(N),
            np.empty(N, dtype=np.int64),
        )
        bufs = _BUFFERS.bufs = (key, logs)
    out: tuple[Any, ...] = bufs[1]
    return out


def _constant(value: float, shape: tuple[int, ...]) -> Any:
    """A read-only (rows, ...) array of ``value``: a view of a per-thread buffer that grows
    as needed (the summary reads the unused log columns and keeps none of them)."""
    key = f"const_{value!r}_{shape[1:]}"
    buf = getattr(_BUFFERS, key, None)
    if buf is None or buf.shape[0] < shape[0]:
        buf = np.full((max(shape[0], 1024), *shape[1:]), value)
        buf.flags.writeable = False
        setattr(_BUFFERS, key, buf)
    return buf[: shape[0]]


def _summary(
    exp: Experiment, rows: int, code: int, axis: int, logs: tuple[Any, ...], coll: tuple[Any, ...]
) -> RunSummary:
    """The run's :class:`RunSummary`, by :func:`summarize` on the logged arrays (views of
    the loop's buffers: the summary keeps numbers, not arrays)."""
    Q, QD, TW, EN, FL = logs
    opt, n = exp.options, exp.robot.n
    bits = (FL[:rows, None] >> np.arange(len(FLAGS))) & 1
    empty, zeros, nan = (
        _constant(0.0, (rows, 0)),
        _constant(0.0, (rows,)),
        _constant(np.nan, (rows,)),
    )
    zeros_n = _constant(0.0, (rows, n))
    pairs = collision_fields(exp, coll, rows)
    log = SimulationLog(
        t=np.arange(rows, dtype=np.float64) * opt.dt,
        q=Q[:rows],
        qdot=QD[:rows],
        camera_twist=TW[:rows],
        s=empty,
        e=empty,
        e1=empty,
        error_norm=EN[:rows],
        q_normalized=zeros_n,
        alpha=nan,
        projector_rank=zeros,
        task_rank=zeros,
        levels=zeros,
        overconstrained=zeros,
        constrained=zeros_n,
        gamma=zeros_n,
        scale=nan,
        flags=np.where(bits != 0, 1.0, np.nan),
        **pairs["log"],
    )
    outcome = _OUTCOMES[code]
    hit = {"axis": axis, "iteration": rows - 1} if outcome == "joint_limit" else None
    return summarize(
        log,
        outcome,
        exp.limits,
        hit,
        dt=opt.dt,
        min_margin=opt.min_margin,
        collision=pairs["collision"],
        distances=pairs["distances"],
    )


def _run_loop(
    exp: Experiment, law: Law, args: tuple[Any, ...], q0: Any = None
) -> tuple[int, int, int, int]:
    """Call the loop kernel until the run ends; a step it hands back (a ``qp`` step for a
    Python solver library, or whose compiled solver failed) is computed by the law itself,
    exactly as the object path does (:mod:`redservo.campaign.loop_handback`). ``q0``: the
    experiment's checked start (:attr:`_Packed.q0`; None: checked here)."""
    from redservo.campaign import loop_handback
    from redservo.campaign.loop_kernel import NEED_SOLVE, closed_loop

    robot, scene, task, law_args, limits, sim, logs, coll = args
    solve = loop_handback.solve_pack(exp, coll)
    if q0 is None:
        q0 = np.array(exp.limits.check(exp.q0, "q0"), dtype=np.float64)
    q = q0.copy()  # the loop moves it
    prev = np.zeros(exp.robot.n)  # the robot starts at rest
    while True:
        rows, code, axis, abort = closed_loop(
            q, prev, robot, scene, task, law_args, limits, sim, logs, solve, coll
        )
        if code != NEED_SOLVE:
            return int(rows), int(code), int(axis), int(abort)
        loop_handback.python_step(exp, law, q, prev, sim, solve)


class _Packed(NamedTuple):
    """The loop's arguments that depend only on the experiment (shared by its methods)."""

    robot: tuple[Any, ...]
    scene: tuple[Any, ...]
    task: tuple[Any, ...]
    limits: tuple[Any, ...]
    sim: tuple[Any, ...]
    q0: Any = None
    """The start, checked against the limits (None: the run checks it and says why)."""


def _pack(exp: Experiment) -> _Packed:
    from redservo.redundancy.packs import limits_pack

    opt, lim, n = exp.options, exp.limits, exp.robot.n
    lp = limits_pack(lim)
    q_min, q_max = np.array(lim.q_min, np.float64), np.array(lim.q_max, np.float64)
    qsat = np.ones(n)
    if opt.qdot_max is not None:
        qsat = np.broadcast_to(np.asarray(opt.qdot_max, dtype=np.float64), (n,)).copy()
    sim = (
        float(opt.constant_lam),
        float(opt.dt),
        float(opt.tolerance),
        bool(opt.stop_at_convergence),
        qsat,
        opt.qdot_max is not None,
        opt.feedforward == "known",
    )
    limits = (lp.rows, lp.has_v, lp.has_a, q_min, q_max)
    try:
        q0 = np.array(lim.check(exp.q0, "q0"), dtype=np.float64)
    except RedservoError:  # the run raises it again, on the object path
        q0 = None
    return _Packed(robot_args(exp), scene_args(exp), task_args(exp), limits, sim, q0)


def _packed(exp: Experiment) -> _Packed | str:
    """The experiment's packed arguments or the reason it is not covered (cached per thread
    for the last experiment, which a campaign sample shares between its methods)."""
    last = getattr(_BUFFERS, "exp", None)
    if last is not None and last[0]() is exp:
        out: _Packed | str = last[1]
        return out
    out = experiment_reason(exp) or _pack(exp)
    _BUFFERS.exp = (weakref.ref(exp), out)
    return out


def fast_summary(exp: Experiment, law: Law) -> RunSummary | None:
    """Run ``law`` on ``exp`` in the compiled loop; None when not covered (:func:`fast_reason`)
    or when the object path would raise (the caller then runs the object path)."""
    packed = _packed(exp)
    if isinstance(packed, str) or law_reason(law) is not None:
        return None
    if collision_reason(exp, law) is not None:
        return None
    try:
        law_args = _law_args(law, exp.robot.n)
    except ConfigurationError:
        return None
    return _covered_summary(exp, law, packed, law_args)


def _covered_summary(
    exp: Experiment, law: Law, p: _Packed, law_args: tuple[Any, ...]
) -> RunSummary | None:
    """:func:`fast_summary` of a run known to be covered, its packs given."""
    logs = _buffers(exp.options.max_iterations, exp.robot.n)
    coll = collision_pack(exp, law)
    args = (p.robot, p.scene, p.task, law_args, p.limits, p.sim, logs, coll)
    rows, code, axis, abort = _run_loop(exp, law, args, p.q0)
    if abort:
        return None
    if not coll[0]:  # no pair measured: the summary reduced in one kernel call, same bits
        outcome = _OUTCOMES[code]
        hit = {"axis": axis, "iteration": rows - 1} if outcome == "joint_limit" else None
        fast = loop_summary(exp, rows, outcome, hit, logs)
        if fast is not None:
            return fast
    return _summary(exp, rows, code, axis, logs, coll)


def fast_run(
    exp: Experiment, method: str, law_options: Mapping[str, Any] | None
) -> tuple[RunSummary | None, str]:
    """``(summary, path)`` of one campaign run on the compiled loop: the summary (None when
    the caller must run the object path) and ``"compiled loop"`` or the reason it is not."""
    ctl = exp.scenario.spec.control
    key = (
        method,
        repr(law_options),
        ctl.method,
        repr(ctl.options),
        ctl.shield,
        ctl.robust,
        ctl.scaling,
    )
    law, args = method_law(key, lambda: campaign_law(exp, method, law_options))
    mode = ("reason", _compiled())  # the law's reason, kept per kernel mode (it may change)
    if mode not in args:
        args[mode] = law_reason(law)
    reason = args[mode]
    packed = _packed(exp)  # the experiment's reason, or its packs (cached for its methods)
    if reason is None and isinstance(packed, str):
        reason = packed
    reason = reason or collision_reason(exp, law)
    if reason is not None:
        return None, reason
    from redservo.campaign.rows import FAST_PATH

    assert not isinstance(packed, str)
    try:
        summary = None
        law_args = cached_law_args(law, exp.robot.n, args)
        if law_args is not None:  # None: the law's options raise (the object path says so)
            summary = _covered_summary(exp, law, packed, law_args)
    except Exception as exc:  # the object path runs it again and records what happens
        return None, f"the compiled loop raised {type(exc).__name__}"
    return summary, FAST_PATH if summary is not None else "the object path would raise"
