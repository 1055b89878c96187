"""Per-method statistics of a campaign and its markdown report (its figures:
:mod:`redservo.campaign.figures`).

See the module docstring of :mod:`redservo.campaign` ("Statistics").
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from redservo.campaign.definition import CampaignDefinition, ErrorSpec, Range
from redservo.campaign.reach import reachable_column
from redservo.campaign.wilson import wilson_interval


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
    shield_runs: int = 0
    """Runs in which the position shield had to act (never a success)."""
    velocity_violation_runs: int = 0
    """Runs in which a command exceeded a velocity limit (must be 0)."""
    peak_velocity_ratio_p95: float = float("nan")
    """95th percentile over runs of the peak |q̇_i| / q̇_max,i."""
    flag_runs: tuple[tuple[str, int], ...] = ()
    """For each diagnostic flag, the number of runs in which it occurred."""
    reachable_runs: int = -1
    """Runs whose goal is reachable (:mod:`redservo.campaign.reach`; -1: unknown), the
    successes among them and the Wilson 95 % interval of that rate."""
    reachable_successes: int = 0
    reach_ci_low: float = float("nan")
    reach_ci_high: float = float("nan")
    collisions: int = 0
    """Runs that ended with a link touching an obstacle or another link (``collision``)."""
    feature_lost: int = 0
    """Runs that ended because the image sensor lost a feature for good (``feature_lost``):
    a failure, not an error; the table shows them with the target lost."""


STAT_COLUMNS = (
    "iterations",
    "max_joint_speed",
    "max_cam_translation",
    "max_cam_rotation",
    "discontinuity",
    "min_margin",
)
"""The always-present float columns of a row that the statistics summarize."""


def _pct(values: Sequence[float] | np.ndarray, q: float) -> float:
    a = np.asarray(values, dtype=float)
    a = a[~np.isnan(a)]
    return float(np.percentile(a, q)) if a.size else float("nan")


def method_stats(method: str, rows: Sequence[Mapping[str, Any]]) -> MethodStats:
    """Summarize the rows of one method (rows as in ``samples.csv``)."""
    outcomes = [r["outcome"] for r in rows]
    cols = {c: np.array([float(r[c]) for r in rows], dtype=float) for c in STAT_COLUMNS}
    cols["peak_velocity_ratio"] = np.array(
        [
            float(r["peak_velocity_ratio"]) if r.get("peak_velocity_ratio") is not None else np.nan
            for r in rows
        ],
        dtype=float,
    )
    return column_stats(
        method,
        np.array([bool(r["success"]) for r in rows], dtype=bool),
        {o: outcomes.count(o) for o in set(outcomes)},
        cols,
        shield_runs=sum(int(r.get("shield_activations") or 0) > 0 for r in rows),
        velocity_runs=sum(int(r.get("velocity_violations") or 0) > 0 for r in rows),
        flag_runs=_flag_runs(rows),
        reachable=reachable_column([str(r.get("reachable") or "") for r in rows]),
    )


def column_stats(
    method: str,
    success: np.ndarray,
    outcomes: Mapping[str, int],
    cols: Mapping[str, np.ndarray],
    *,
    shield_runs: int,
    velocity_runs: int,
    flag_runs: tuple[tuple[str, int], ...],
    reachable: np.ndarray | None = None,
) -> MethodStats:
    """:class:`MethodStats` of one method from its columns (one entry per run): ``success``,
    the number of runs of each outcome, the float columns of ``samples.csv`` named in
    :class:`MethodStats` (NaN: no value) and the counts of runs with the shield, a velocity
    violation and each flag (:class:`redservo.campaign.table.RunTable`); ``reachable``: per
    run, whether its goal is reachable (None: unknown)."""
    n = int(success.size)
    k = int(success.sum())
    lo, hi = wilson_interval(k, n)
    ok = np.zeros(0, bool) if reachable is None else reachable
    nr, kr = (int(ok.sum()), int((ok & success).sum())) if reachable is not None else (-1, 0)
    rlo, rhi = (float("nan"),) * 2 if reachable is None else wilson_interval(kr, nr)
    named: tuple[str, ...] = ("converged", "joint_limit", "target_lost", "max_iterations")
    named += ("collision", "feature_lost")
    return MethodStats(
        method=method,
        runs=n,
        successes=k,
        success_rate=k / n if n else float("nan"),
        ci_low=lo,
        ci_high=hi,
        limit_hits=outcomes.get("joint_limit", 0),
        collisions=outcomes.get("collision", 0),
        target_lost=outcomes.get("target_lost", 0),
        feature_lost=outcomes.get("feature_lost", 0),
        max_iterations=outcomes.get("max_iterations", 0),
        other_failures=sum(c for o, c in outcomes.items() if o not in named),
        iterations_median=_pct(cols["iterations"][success], 50),
        iterations_p90=_pct(cols["iterations"][success], 90),
        joint_speed_median=_pct(cols["max_joint_speed"], 50),
        joint_speed_p95=_pct(cols["max_joint_speed"], 95),
        cam_translation_median=_pct(cols["max_cam_translation"], 50),
        cam_translation_p95=_pct(cols["max_cam_translation"], 95),
        cam_rotation_median=_pct(cols["max_cam_rotation"], 50),
        cam_rotation_p95=_pct(cols["max_cam_rotation"], 95),
        discontinuity_median=_pct(cols["discontinuity"], 50),
        min_margin_median=_pct(cols["min_margin"], 50),
        shield_runs=shield_runs,
        velocity_violation_runs=velocity_runs,
        peak_velocity_ratio_p95=_pct(cols["peak_velocity_ratio"], 95),
        flag_runs=flag_runs,
        reachable_runs=nr,
        reachable_successes=kr,
        reach_ci_low=rlo,
        reach_ci_high=rhi,
    )


def _flag_runs(rows: Sequence[Mapping[str, Any]]) -> tuple[tuple[str, int], ...]:
    counts: dict[str, int] = {}
    for r in rows:
        for label in str(r.get("flags") or "").split(";"):
            if label:
                counts[label] = counts.get(label, 0) + 1
    return tuple(sorted(counts.items()))


def _g(v: float, fmt: str = ".3g") -> str:
    return "—" if math.isnan(v) else format(v, fmt)


def stats_table(stats: Iterable[MethodStats]) -> str:
    """Return a markdown table, one row per method, of :class:`MethodStats`."""
    head = (
        "| method | success [95% CI] | success among reachable [95% CI] | limit hits | collisions | shield runs | target lost | max. iter. | "
        "iterations med (p90) | peak q̇ med (p95) | p95 peak q̇/limit | "
        "peak cam. v (m/s) med (p95) | peak cam. ω (rad/s) med (p95) | discontinuity med | "
        "min margin med |\n"
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    lines = []
    for s in stats:
        other = f" (+{s.other_failures} errors)" if s.other_failures else ""
        lost = f" (+{s.feature_lost} feature lost)" if s.feature_lost else ""
        lines.append(
            f"| {s.method} | {s.successes}/{s.runs} = {_g(100 * s.success_rate, '.1f')} % "
            f"[{100 * s.ci_low:.1f}, {100 * s.ci_high:.1f}]{other} | {_reach(s)} | "
            f"{s.limit_hits} | {s.collisions} | "
            f"{s.shield_runs} | {s.target_lost}{lost} | {s.max_iterations} | "
            f"{_g(s.iterations_median, '.0f')} ({_g(s.iterations_p90, '.0f')}) | "
            f"{_g(s.joint_speed_median)} ({_g(s.joint_speed_p95)}) | "
            f"{_g(s.peak_velocity_ratio_p95, '.2f')} | "
            f"{_g(s.cam_translation_median)} ({_g(s.cam_translation_p95)}) | "
            f"{_g(s.cam_rotation_median)} ({_g(s.cam_rotation_p95)}) | "
            f"{_g(s.discontinuity_median)} | {_g(s.min_margin_median, '.3f')} |"
        )
    return head + "\n".join(lines)


def _reach(s: MethodStats) -> str:
    """The table's cell of the success among the reachable runs."""
    if s.reachable_runs < 0:
        return "—"
    k, n = s.reachable_successes, s.reachable_runs
    rate = _g(100 * k / n if n else float("nan"), ".1f")
    return f"{k}/{n} = {rate} % [{100 * s.reach_ci_low:.1f}, {100 * s.reach_ci_high:.1f}]"


def _sample_count(n: int, counts: Mapping[str, int]) -> str:
    """The sample count of the heading: ``N = n samples per method`` when every method has its
    ``n`` rows; otherwise the N each method actually completed, never the N requested
    (docs/campaigns.md, "Completeness")."""
    if all(c == n for c in counts.values()):
        return f"N = {n} samples per method"
    done = ", ".join(f"{m} {c}" for m, c in counts.items())
    return (
        f"INCOMPLETE campaign: N completed per method: {done} (of the {n} samples requested; "
        "rerun the campaign to compute the missing runs)"
    )


def _heading(
    defn: CampaignDefinition, n: int, seed: int, counts: Mapping[str, int], redraws: int
) -> str:
    """The text above the statistics table: the set-up, N (per method when they differ from
    the ``n`` requested: ``counts``, rows per method) and the definition of success;
    ``redraws``: the invalid starts re-drawn."""
    st, tg = defn.start, defn.target
    data = defn.scenario.data
    rho = float(data["robot"].get("rho", 0.1))
    ctl, sim = data["control"], data.get("simulation", {})
    cap = int(sim.get("max_iterations", 1000))

    def rng3(r: Sequence[Range]) -> str:
        return ", ".join(f"[{lo:g}, {hi:g}]" for lo, hi in r)

    if sim.get("stop_at_convergence", True):
        success = (
            f"Success = converged (‖e1‖ < {float(sim.get('tolerance', 1e-3)):g}) within {cap} "
            "iterations with no limit hit and the target never lost, every joint at least "
            f"{100 * float(sim.get('min_margin', 0.01)):g} % of its range from its limits all "
            "along, no velocity or acceleration limit exceeded, and the position shield never "
            "acted (a run that needed the shield did not avoid the limit by itself)."
        )
    else:
        success = (
            f"Tracking task: every run lasts {cap} iterations; success = final ‖e1‖ < "
            f"{float(sim.get('tolerance', 1e-3)):g} with no limit hit and the target never "
            "lost, the same safety conditions (margin, rate limits, no shield action); the "
            "iteration columns are then the run length."
        )
    return (
        f"## Campaign {defn.name}\n\n"
        f"{defn.description}\n\n"
        f"Base scenario `{defn.scenario.name}` (λ = {float(ctl.get('lam', 0.5)):g} 1/s, "
        f"dt = {float(ctl.get('dt', 0.04)):g} s); {_sample_count(n, counts)}, seed {seed}. "
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


def flag_table(stats: Iterable[MethodStats]) -> str:
    """Markdown table: for each method, the number of runs in which each flag occurred."""
    stats = list(stats)
    labels = sorted({label for s in stats for label, _ in s.flag_runs})
    if not labels:
        return "No diagnostic flag was raised in any run.\n"
    head = "| method | " + " | ".join(labels) + " |\n|---|" + "---:|" * len(labels) + "\n"
    lines = []
    for s in stats:
        counts = dict(s.flag_runs)
        lines.append(f"| {s.method} | " + " | ".join(str(counts.get(k, 0)) for k in labels) + " |")
    return head + "\n".join(lines) + "\n"
