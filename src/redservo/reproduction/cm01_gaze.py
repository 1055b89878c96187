"""CM01 §V-A1–3, Figs. 8–12: the Afma6 eye-in-hand camera gazes at a point (m = 2, n = 6, n_a = 4).

The scenario ``cm01-gaze`` starts near the limits of axes 1 and 3 (both in their
bands) with axis 5 just above its lower threshold; the task brings the point to
the image centre. The runs are those of CM01's Figs. 9–12: no avoidance, the
gradient projection method with several fixed gains α and with the automatic
gain of eq. 9, and the four variants of the iterative scheme. Every claim of
§V-A (literature.md §D.2) is turned into a verdict computed from the logs by the
criterion stated in its ``evidence``/``note``.

Axes are numbered from 1 in claims and figures (axis 1 = ``q[0]``).

Decisions (listed for docs/decisions.md):

* **Scenario.** CM01 gives neither the start nor the target; both come from a
  random search documented in the scenario file and in :data:`NOTES`. λ = 0.3 1/s,
  dt = 0.08 s (CM01's period).
* **α values.** Ours are 0.25 (fails), 0.5 (the smallest of our grid that succeeds),
  2 (CM01's moderate gain, Fig. 10a) and 200 (CM01's huge gain, Fig. 10b). CM01's
  threshold between failure and success is 1.5/2; ours is 0.25/0.5 because the
  gain of the gradient term depends on the scaling of e2 (``s_i/Δq_i``, eq. 6),
  on λ dt and on the geometry, none of which CM01 reports.
* **Thresholds.** ρ = 0.1 puts q̃ at ±0.8 in normalized coordinates (CM01 eq. 3),
  not at the ±0.9 of CM01's text; "band" below means ``|q_norm| >= 0.8``.
* **Criteria** (tolerances are stated in each claim's evidence):

  - an axis *crosses* its threshold when its normalized band excess
    ``max(|q_norm| - (1 - 2ρ), 0)`` exceeds ``1e-9``;
  - *oscillations on q1*: sign reversals of q̇1 counted over the steps where
    ``|q̇1|`` exceeds 1 % of its maximum over the run;
  - *exponential decay* of the image error: a least-squares line through
    ``log ‖e‖`` versus t has R² >= 0.99 and a rate within 15 % of the nominal
    ``-ln(1 - λ dt)/dt``;
  - *large-gain transient of gpm-auto*: the peak α lies in the first quarter of
    the run and is at least 10 times the median α of the second half;
  - *discontinuity*: the simulator's ``max ‖q̇_{k+1} - q̇_k‖``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.reproduction.base import Claim, ExperimentSpec, Runs, RunSpec
from redservo.simulation import SimulationLog, SimulationResult

__all__ = ["EXPERIMENTS", "SPEC"]

ALPHA_SMALL = 0.25
"""A gain too small for gpm: a joint limit is hit (CM01: 1.5)."""
ALPHA_ENOUGH = 0.5
"""The smallest gain of our grid {0.25, 0.5, 1, 1.5, 2, 3, 5, ...} with which gpm succeeds."""
ALPHA_MODERATE = 2.0
"""CM01's moderate gain (Figs. 9, 10a)."""
ALPHA_HUGE = 200.0
"""CM01's huge gain (Figs. 9, 10b)."""

CROSS_TOL = 1e-9
"""Normalized band excess above which an axis counts as having crossed its threshold."""
STOP_TOL = 1e-9
"""|q̇_k| (rad/s or m/s) below which a constrained axis counts as stopped."""

_GPM = {a: f"gpm alpha={a:g}" for a in (ALPHA_SMALL, ALPHA_ENOUGH, ALPHA_MODERATE, ALPHA_HUGE)}
_AUTO = "gpm-auto"
_ITERATIVE = ("iterative-basic", "iterative", "iterative-smooth", "iterative-smooth-e2")

RUNS: tuple[RunSpec, ...] = (
    RunSpec("classical", "classical"),
    *(RunSpec(label, "gpm", {"alpha": a}) for a, label in _GPM.items()),
    RunSpec(_AUTO, "gpm-auto"),
    RunSpec("iterative-basic", "iterative-basic"),
    RunSpec("iterative", "iterative"),
    RunSpec("iterative-smooth", "iterative-smooth"),
    RunSpec("iterative-smooth-e2", "iterative-smooth-e2", {"alpha": ALPHA_MODERATE}),
)
"""The runs of Figs. 9–12."""

NOTES = (
    "CM01 gives neither the start pose nor the target. The start (normalized q1 = -0.864 and "
    "q3 = +0.898, both in their bands; q5 = -0.770, 0.039 rad above its lower threshold; "
    "A = 1.405 rad) and the point (0.134, 0.279, 0.866) m in the start camera frame come from "
    "a throwaway random search of about 10 000 draws (q1, q3 in their bands, q5 just above its "
    "threshold, A anywhere, a point at 0.6-2.5 m anywhere in the image). We kept the draws "
    "where classical hits axis 1, iterative-basic lets q5 cross its threshold while iterative "
    "keeps it out, the other iterative variants converge, gpm fails with a small α and "
    "succeeds with a larger one, and gpm-auto stops axis 1 first and axis 5 later (searched "
    "at λ = 0.5 1/s, dt = 0.08 s). Re-run at λ = 0.3 1/s (dt = 0.08 s, CM01's period), only "
    "one of them also had gpm-auto converge with a large early α transient and α = 200 "
    "make q1 oscillate; it is this scenario, where classical hits axis 1 at iteration 55 "
    "(CM01: 54). The α values (0.25, 0.5, 2, 200) differ from CM01's (1.5 fails, ≥ 2 "
    "succeeds) because the gradient's gain depends on the scaling of e2, on λ dt and on the "
    "geometry. With ρ = 0.1 the thresholds are at ±0.8 in normalized coordinates (CM01 eq. 3), "
    "not at the ±0.9 of CM01's text. The quick version (tests) doubles dt to 0.16 s."
)


# -- metrics on the logs ---------------------------------------------------------------------


def _threshold(runs: Runs) -> float:
    """Normalized position of the thresholds, ``1 - 2ρ``."""
    return 1.0 - 2.0 * runs.base.limits.rho


def _excess(log: SimulationLog, thr: float) -> FloatArray:
    """(N, n) normalized band excess ``max(|q_norm| - thr, 0)``."""
    return np.maximum(np.abs(log.q_normalized) - thr, 0.0)


def _first(mask: NDArray[Any]) -> int | None:
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def _reversals(x: FloatArray, rel: float = 0.01) -> int:
    """Sign reversals of ``x`` over the samples with ``|x| > rel max|x|``."""
    if x.size == 0:
        return 0
    big = x[np.abs(x) > rel * float(np.max(np.abs(x)))]
    return int(np.count_nonzero(np.diff(np.sign(big)) != 0))


def _hit(r: SimulationResult) -> tuple[int | None, int | None]:
    """(axis numbered from 1, iteration) of the joint limit hit, or (None, None)."""
    h = r.summary["limit_hit"]
    return (h["axis"] + 1, h["iteration"]) if h else (None, None)


def _succeeded(r: SimulationResult) -> bool:
    return r.outcome == "converged"


def _decay(t: FloatArray, error_norm: FloatArray) -> tuple[float, float]:
    """Fit ``log ‖e‖ = c - rate t`` by least squares; return (rate in 1/s, R²).

    Args:
        t: (N,) times (s), N >= 2.
        error_norm: (N,) positive error norms.
    """
    y = np.log(np.maximum(error_norm, 1e-300))
    A = np.vstack([t, np.ones_like(t)]).T
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    resid = y - A @ coef
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid**2)) / ss if ss > 0 else 1.0
    return -float(coef[0]), r2


def _speed(r: SimulationResult) -> float:
    return float(r.summary["max_camera_speed"]["translation"])


# -- claims ----------------------------------------------------------------------------------


def _claims(runs: Runs) -> list[Claim]:
    thr = _threshold(runs)
    opt = runs.base.options
    lam, dt = opt.constant_lam, opt.dt
    out: list[Claim] = []

    # classical ----------------------------------------------------------------------------
    cl = runs["classical"]
    axis, it = _hit(cl)
    out.append(
        Claim(
            "With no avoidance (classical) a joint limit is hit: axis 1 at iteration 54 (CM01 §V-A2)",
            cl.outcome == "joint_limit" and axis == 1,
            {"outcome": cl.outcome, "axis": axis, "iteration": it, "CM01 iteration": 54},
        )
    )

    # gpm ------------------------------------------------------------------------------------
    small = runs[_GPM[ALPHA_SMALL]]
    axis, it = _hit(small)
    out.append(
        Claim(
            f"gpm with too small an α (ours {ALPHA_SMALL:g}; CM01 1.5) hits a joint limit",
            small.outcome == "joint_limit",
            {"alpha": ALPHA_SMALL, "outcome": small.outcome, "axis": axis, "iteration": it},
            note="CM01's α = 1.5 hits axis 5 after iteration 180; see the next claim for the axis.",
        )
    )
    out.append(
        Claim(
            "... and the limit it hits is that of axis 5 (CM01: α = 1.5 hits axis 5)",
            axis == 5,
            {"axis": axis, "iteration": it},
            note=(
                "Not reproduced: here the too-small gain lets axis 1 reach its limit. In our "
                "search (about 10 000 draws) the few draws where a small α failed on axis 5, "
                "as in CM01, also had gpm-auto hitting a limit or iterative diverging, so none "
                "was kept."
                if axis != 5
                else ""
            ),
        )
    )
    ok = {a: runs[_GPM[a]] for a in (ALPHA_ENOUGH, ALPHA_MODERATE)}
    out.append(
        Claim(
            f"A larger α succeeds (ours α ≥ {ALPHA_ENOUGH:g}: {ALPHA_ENOUGH:g} and "
            f"{ALPHA_MODERATE:g} tried; CM01 α ≥ 2)",
            all(_succeeded(r) for r in ok.values()),
            {
                **{f"outcome α={a:g}": r.outcome for a, r in ok.items()},
                **{f"iterations α={a:g}": r.summary["iterations"] for a, r in ok.items()},
            },
        )
    )
    huge, mod = runs[_GPM[ALPHA_HUGE]], runs[_GPM[ALPHA_MODERATE]]
    v_h, v_m = _speed(huge), _speed(mod)
    out.append(
        Claim(
            f"A very large α ({ALPHA_HUGE:g}) gives large camera velocity peaks "
            "(CM01: translation velocities of nearly 1 m/s)",
            v_h >= 0.5 and v_h >= 10.0 * v_m,
            {
                f"max translation speed α={ALPHA_HUGE:g} (m/s)": v_h,
                f"max translation speed α={ALPHA_MODERATE:g} (m/s)": v_m,
                "ratio": v_h / v_m if v_m > 0 else float("inf"),
                "criterion": ">= 0.5 m/s and >= 10x the moderate α",
            },
        )
    )
    rev_h, rev_m = _reversals(huge.log.qdot[:, 0]), _reversals(mod.log.qdot[:, 0])
    out.append(
        Claim(
            f"... and oscillations on q1 (CM01 Fig. 9a, α = {ALPHA_HUGE:g})",
            rev_h >= 10 and rev_h >= 5 * max(rev_m, 1),
            {
                f"q̇1 sign reversals α={ALPHA_HUGE:g}": rev_h,
                f"q̇1 sign reversals α={ALPHA_MODERATE:g}": rev_m,
                f"iterations α={ALPHA_HUGE:g}": huge.summary["iterations"],
                "criterion": ">= 10 and >= 5x the moderate α (|q̇1| > 1 % of its max)",
            },
        )
    )

    # gpm-auto -------------------------------------------------------------------------------
    auto = runs[_AUTO]
    c = auto.log.constrained
    per_it = c.sum(axis=1)
    stopped_speed = float(np.max(np.abs(auto.log.qdot[c > 0]))) if c.any() else float("nan")
    axes_stopped = [int(j) + 1 for j in np.flatnonzero(c.any(axis=0))]
    out.append(
        Claim(
            "gpm-auto stops one axis at a time (CM01 §II-C)",
            bool(c.any()) and int(per_it.max()) == 1 and stopped_speed <= STOP_TOL,
            {
                "max axes stopped at once": int(per_it.max()),
                "axes stopped": axes_stopped,
                "max |q̇_k| of the stopped axis": stopped_speed,
                "outcome": auto.outcome,
            },
        )
    )
    a = auto.log.alpha
    n = a.size
    k_peak = int(np.nanargmax(a))
    a_late = float(np.nanmedian(a[n // 2 :]))
    first1, first5 = _first(c[:, 0]), _first(c[:, 4])
    out.append(
        Claim(
            "gpm-auto computes large α values early in the run, a large-gain transient "
            "(CM01 Fig. 10c: unstable at the beginning)",
            k_peak <= n // 4 and float(a[k_peak]) >= 10.0 * a_late,
            {
                "peak α": float(a[k_peak]),
                "at iteration": k_peak,
                "of iterations": n,
                "α at iteration 0": float(a[0]),
                "median α, second half": a_late,
                "max camera speed / classical's": _speed(auto) / _speed(cl),
                "criterion": "peak in the first quarter and >= 10x the late median",
            },
            note=(
                "The peak comes when axis 5 takes over (its e2 is then still tiny), not at "
                "iteration 0."
                if k_peak == first5 and k_peak > 0
                else ""
            ),
        )
    )
    out.append(
        Claim(
            "gpm-auto first stops axis 1, then axis 5 overtakes it as the most critical axis "
            "(CM01: after iteration 80)",
            first1 is not None and first5 is not None and first1 < first5,
            {
                "first iteration axis 1 stopped": first1,
                "first iteration axis 5 stopped": first5,
                "outcome": auto.outcome,
            },
        )
    )

    # iterative-basic ------------------------------------------------------------------------
    base_q0 = runs.base.limits.normalized(runs.base.q0)
    outside = np.flatnonzero(np.abs(base_q0) < thr)
    inside = np.flatnonzero(np.abs(base_q0) >= thr)
    basic = runs["iterative-basic"]
    cb = basic.log.constrained
    stopped = float(np.max(np.abs(basic.log.qdot[cb > 0]))) if cb.any() else float("nan")
    out.append(
        Claim(
            "iterative-basic stops the axes in the critical band (CM01: q1 is stopped from the start)",
            bool(cb.any()) and stopped <= STOP_TOL and _first(cb[:, 0]) == 0,
            {
                "axes stopped": [int(j) + 1 for j in np.flatnonzero(cb.any(axis=0))],
                "max |q̇_k| on a stopped axis": stopped,
                "first iteration axis 1 stopped": _first(cb[:, 0]),
            },
        )
    )
    exb = _excess(basic.log, thr)[:, outside]
    crossed = [int(outside[j]) + 1 for j in np.flatnonzero(exb.max(axis=0) > CROSS_TOL)]
    enter5 = _first(_excess(basic.log, thr)[:, 4] > CROSS_TOL)
    out.append(
        Claim(
            "iterative-basic: an axis that starts outside the band still crosses its threshold "
            "(CM01: q5 enters the band at iteration 30 and crosses q̃5)",
            bool(crossed),
            {
                "axes crossing": crossed,
                "first iteration q5 beyond q̃5": enter5,
                "deepest q5 crossing (normalized)": float(_excess(basic.log, thr)[:, 4].max()),
                "q5 stopped after crossing": enter5 is not None and bool(cb[enter5:, 4].any()),
                "outcome": basic.outcome,
            },
            note=(
                "The crossing is small: about one control step of the null-space motion that "
                "stops axis 1, which the single level of eqs. 10-12 (predicting with J1⁺e1 "
                "only) does not foresee."
            ),
        )
    )

    # iterative ------------------------------------------------------------------------------
    itr = runs["iterative"]
    exi = _excess(itr.log, thr)[:, outside]
    exi_max = float(exi.max()) if exi.size else 0.0
    c5 = itr.log.constrained[:, 4]
    releases = int(np.count_nonzero(np.diff(c5) < 0))
    out.append(
        Claim(
            "iterative keeps every axis that starts outside the band out of it, q5 approaching "
            "q̃5 in 'stairs' (CM01 Fig. 11)",
            _succeeded(itr) and exi_max <= CROSS_TOL and releases >= 1,
            {
                "axes starting outside the band": [int(j) + 1 for j in outside],
                "max band excess of those axes (normalized)": exi_max,
                "closest approach of q5 to q̃5 (normalized)": float(
                    np.min(thr - np.abs(itr.log.q_normalized[:, 4]))
                ),
                "times axis 5 is released then stopped again (stairs)": releases,
                "outcome": itr.outcome,
            },
        )
    )

    # iterative-smooth -----------------------------------------------------------------------
    sm = runs["iterative-smooth"]
    out.append(
        Claim(
            "iterative-smooth reaches no joint limit, using the band up to q̄ (CM01 §V-A3)",
            _succeeded(sm) and float(sm.summary["min_margin"]) > 0.0,
            {
                "outcome": sm.outcome,
                "min margin (fraction of range)": float(sm.summary["min_margin"]),
                "deepest |q_norm|, smooth": float(np.abs(sm.log.q_normalized).max()),
                "deepest |q_norm|, iterative": float(np.abs(itr.log.q_normalized).max()),
            },
        )
    )
    n_sm, n_it = sm.summary["iterations"], itr.summary["iterations"]
    out.append(
        Claim(
            "iterative-smooth converges faster than iterative (CM01 §V-A3)",
            _succeeded(sm) and _succeeded(itr) and n_sm < n_it,
            {"iterations, smooth": n_sm, "iterations, iterative": n_it},
            note=(
                "Not reproduced: every law here realizes J1 q̇ = -λ e1 exactly, so the image "
                "error decays at the same rate whatever the null-space motion; the counts "
                "differ only by the non-linearity of the projection. CM01's faster convergence "
                "on the real robot probably comes from the velocity jumps of the non-smooth "
                "variants, which a perfect velocity-controlled simulation does not feel."
                if not n_sm < n_it
                else ""
            ),
        )
    )
    d_sm, d_it = float(sm.summary["discontinuity"]), float(itr.summary["discontinuity"])
    out.append(
        Claim(
            "The discontinuities of iterative-smooth are smaller than those of iterative "
            "(CM01 Fig. 12c vs 12b)",
            d_sm < d_it,
            {"max ‖Δq̇‖ smooth": d_sm, "max ‖Δq̇‖ iterative": d_it, "ratio": d_sm / d_it},
        )
    )

    # iterative-smooth-e2 --------------------------------------------------------------------
    e2 = runs["iterative-smooth-e2"]
    ex_e2, ex_sm = _excess(e2.log, thr), _excess(sm.log, thr)
    ex0 = _excess(e2.log, thr)[0]
    back = bool(np.all(ex_e2[-1, inside] < ex0[inside]))
    less = bool(np.all(ex_e2[-1] <= ex_sm[-1] + CROSS_TOL) and ex_e2[-1].sum() < ex_sm[-1].sum())
    out.append(
        Claim(
            "iterative-smooth-e2 moves the axes away from the band (CM01 §V-A3, Fig. 6)",
            _succeeded(e2) and back and less,
            {
                "axes in the band at the start": [int(j) + 1 for j in inside],
                "their band excess at the start": [float(ex0[j]) for j in inside],
                "their band excess at the end": [float(ex_e2[-1, j]) for j in inside],
                "total final excess, with e2": float(ex_e2[-1].sum()),
                "total final excess, smooth without e2": float(ex_sm[-1].sum()),
                "criterion": "axes in the band end less deep than they started, and no axis "
                "ends deeper than without e2",
            },
        )
    )

    # Fig. 8: exponential decay in every successful run ----------------------------------------
    nominal = -math.log(1.0 - lam * dt) / dt  # ‖e‖ shrinks by (1 - λ dt) per step
    fits = {
        label: _decay(r.log.t, r.log.error_norm)
        for label, r in runs.results.items()
        if _succeeded(r)
    }
    good = {
        label: abs(rate - nominal) <= 0.15 * nominal and r2 >= 0.99
        for label, (rate, r2) in fits.items()
    }
    out.append(
        Claim(
            "Every successful run shows the exponential decay of the image error of Fig. 8b",
            bool(fits) and all(good.values()),
            {
                "successful runs": len(fits),
                "nominal rate (1/s)": nominal,
                "fitted rates (1/s)": [round(v[0], 4) for v in fits.values()],
                "min R²": min(v[1] for v in fits.values()) if fits else float("nan"),
                "runs failing the criterion": [k for k, v in good.items() if not v],
                "criterion": "rate within 15 % of nominal, R² >= 0.99",
            },
        )
    )
    return out


# -- figures ---------------------------------------------------------------------------------


def _velocity_grid(
    runs: Runs, labels: Sequence[str], path: Path, title: str, *, with_alpha: bool = False
) -> Path:
    from redservo.plots import _plt, save

    plt = _plt()
    names = runs.base.robot.joint_names
    ncol = 3 if with_alpha else 2
    fig, axs = plt.subplots(
        len(labels), ncol, figsize=(4.2 * ncol, 2.4 * len(labels)), squeeze=False
    )
    for row, label in zip(axs, labels, strict=True):
        log = runs[label].log
        for j in range(log.qdot.shape[1]):
            row[0].plot(log.qdot[:, j], lw=1.0, label=f"q̇{j + 1} ({names[j]})")
        row[0].set_title(f"{label}: joint velocities", fontsize=9)
        row[0].set_ylabel("m/s, rad/s")
        for j, comp in enumerate(("vx", "vy", "vz", "ωx", "ωy", "ωz")):
            row[1].plot(log.camera_twist[:, j], lw=1.0, ls="-" if j < 3 else "--", label=comp)
        row[1].set_title(f"{label}: camera velocity", fontsize=9)
        row[1].set_ylabel("m/s, rad/s")
        if with_alpha:
            row[2].semilogy(np.where(log.alpha > 0, log.alpha, np.nan), lw=1.2, color="k")
            row[2].set_title(f"{label}: α", fontsize=9)
        for ax in row:
            ax.set_xlabel("iteration")
        row[0].legend(fontsize=6, ncol=2, loc="best")
        row[1].legend(fontsize=6, ncol=2, loc="best")
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


def _axes_figure(runs: Runs, labels: Sequence[str], path: Path, title: str) -> Path:
    """Normalized axes 1 and 5 of several runs, zoomed on the side of the limits they approach.

    The real limits (±1, solid) and the thresholds (±(1 - 2ρ), dashed) are drawn; a
    cross marks the iteration at which a run hit a joint limit.
    """
    from redservo.plots import _plt, save

    plt = _plt()
    thr = _threshold(runs)
    fig, axs = plt.subplots(2, 1, figsize=(7.5, 6.0), sharex=True)
    for ax, j in zip(axs, (0, 4), strict=True):
        data = np.concatenate([runs[label].log.q_normalized[:, j] for label in labels])
        lo, hi = float(data.min()), float(data.max())
        for label in labels:
            r = runs[label]
            (line,) = ax.plot(r.log.q_normalized[:, j], lw=1.2, label=label)
            if r.outcome == "joint_limit":
                ax.plot(len(r.log) - 1, r.log.q_normalized[-1, j], "x", color=line.get_color())
        marks = [y for y in (-1.0, -thr, thr, 1.0) if lo - 0.25 <= y <= hi + 0.25]
        for y in marks:
            ax.axhline(
                y, color="k" if abs(y) == 1.0 else "0.5", lw=0.8, ls="-" if abs(y) == 1.0 else "--"
            )
        ax.set_ylim(min([lo, *marks]) - 0.02, max([hi, *marks]) + 0.02)
        ax.set_ylabel(f"q{j + 1} (normalized)")
    axs[0].legend(fontsize=7, loc="best")
    axs[-1].set_xlabel("iteration")
    axs[0].set_title(
        title + f"\n(thresholds ±{thr:g} dashed, limits ±1 solid, x = limit hit)", fontsize=9
    )
    return save(fig, path)


def _fig08(runs: Runs, path: Path) -> Path:
    from redservo.plots import _plt, save

    plt = _plt()
    exp = runs.experiments["iterative-smooth"]
    log = runs["iterative-smooth"].log
    cam = exp.camera
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(14, 4))
    uv = cam.normalized_to_pixel(log.s[:, :2])
    a.plot(uv[:, 0], uv[:, 1], lw=1.2)
    a.plot(uv[0, 0], uv[0, 1], "o", color="tab:red", ms=5, label="start")
    a.plot(uv[-1, 0], uv[-1, 1], "s", color="tab:green", ms=5, label="end")
    ustar = cam.normalized_to_pixel(exp.task.s_star[:2])
    a.plot(ustar[0], ustar[1], "+", color="k", ms=12, label="P*")
    a.set_xlim(0, cam.width)
    a.set_ylim(cam.height, 0)
    a.set_aspect("equal")
    a.set_xlabel("u (px)")
    a.set_ylabel("v (px)")
    a.legend(fontsize=7)
    a.set_title("(a) image trajectory of the point (iterative-smooth)", fontsize=9)
    b.plot(log.e[:, 0], label="x - x*")
    b.plot(log.e[:, 1], label="y - y*")
    b.axhline(0.0, color="0.5", lw=0.8)
    b.set_xlabel("iteration")
    b.set_ylabel("normalized image units")
    b.legend(fontsize=7)
    b.set_title("(b) error P - P* (iterative-smooth)", fontsize=9)
    for label, r in runs.results.items():
        if _succeeded(r):
            c.semilogy(r.log.error_norm, lw=1.0, label=label)
    c.set_xlabel("iteration")
    c.set_ylabel("‖P - P*‖")
    c.legend(fontsize=6)
    c.set_title("(c) every successful run", fontsize=9)
    fig.suptitle("CM01 Fig. 8: gazing at a point", fontsize=10)
    return save(fig, path)


def _figures(runs: Runs, out_dir: Path) -> list[Path]:
    gpm_labels = ["classical", *_GPM.values(), _AUTO]
    return [
        _fig08(runs, out_dir / "fig08_image_and_error.png"),
        _axes_figure(
            runs,
            gpm_labels,
            out_dir / "fig09_gpm_axes_1_5.png",
            "CM01 Fig. 9: gradient projection, axes 1 and 5",
        ),
        _velocity_grid(
            runs,
            [_GPM[ALPHA_MODERATE], _GPM[ALPHA_HUGE], _AUTO],
            out_dir / "fig10_gpm_control.png",
            f"CM01 Fig. 10: control laws for α = {ALPHA_MODERATE:g}, α = {ALPHA_HUGE:g} "
            "and automatic α",
            with_alpha=True,
        ),
        _axes_figure(
            runs,
            _ITERATIVE,
            out_dir / "fig11_iterative_axes_1_5.png",
            "CM01 Fig. 11: iterative approach, axes 1 and 5",
        ),
        _velocity_grid(
            runs,
            _ITERATIVE,
            out_dir / "fig12_iterative_control.png",
            "CM01 Fig. 12: control laws of the iterative approach",
        ),
    ]


SPEC = ExperimentSpec(
    id="cm01-gaze",
    title="CM01 §V-A1–3: the Afma6 gazes at a point (m = 2, n = 6, n_a = 4)",
    paper="Chaumette & Marchand 2001, §V-A1–3, Figs. 8–12",
    scenario="cm01-gaze",
    runs=RUNS,
    figures=_figures,
    claims=_claims,
    fast=("control.dt=0.16",),
    notes=NOTES,
)
"""The experiment of CM01 §V-A1–3."""

EXPERIMENTS: tuple[ExperimentSpec, ...] = (SPEC,)
