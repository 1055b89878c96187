"""CM01 §V-B1 (Figs. 16-17): the humanoid torso positions its eyes wrt a sphere.

``P = (xc, yc, a)`` (docs/formulas.md §3.3), three constraints, six free DOF. Runs:
``classical``, ``iterative`` and ``iterative-smooth`` with the exact interaction matrix, and
``iterative-smooth`` with CM01's eq. 27 in two readings:

* ``eq. 27 as printed`` (:data:`EQ27`): the constant matrix of eq. 27, computed once at the
  desired value ``P* = (0, 0, πR*²)`` with the desired distance ``z_d`` — what CM01
  prints ("L at P = P_d") and what a constant-matrix servo uses;
* ``eq. 27 at current P`` (:data:`EQ27_CURRENT`, a documented alternative): the same
  formula re-evaluated at every iteration at the current ``(xc, yc, a)`` with ``R² = a/π``
  and ``1/z_d`` from the current limb plane (``features[0].variant = "paper"``).

*Area convergence rate*: the slope of ``-ln|a - a*|`` against time (s), fitted by least
squares over the iterations where ``|a - a*|`` lies between ``1e-4`` and ``1e-1`` of its
start value (:func:`~redservo.reproduction.metrics.decay_rate`). Eq. 27's area entry
``πR²/z_d`` is about half the exact ``2πR²(1 + R²)/z_d`` (docs/formulas.md §3.3, §14 item
11), so with the same λ the command asks for ``2(1 + R²)`` times the area change it expects:
the area converges about twice as fast (checked against ``2(1 + R*²)`` within
``RATE_TOLERANCE``).

Fig. 16 (the torso model) is drawn here, once (:func:`~redservo.reproduction.cm01_humanoid.
fig16_humanoid_model`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.experiment.build import Experiment
from redservo.features.sphere import sphere_paper_interaction
from redservo.records.summary import SUCCESS_MARGIN
from redservo.reproduction.base import ExperimentSpec, Runs, RunSpec
from redservo.reproduction.checks import IMPL, PAPER, Check, Verdict, registrar
from redservo.reproduction.cm01_humanoid import (
    GROUP_ORDER,
    fig16_humanoid_model,
    group_panel,
)
from redservo.reproduction.metrics import decay_rate, hit, succeeded
from redservo.robots.humanoid import JOINT_GROUPS
from redservo.task import VisualTask

__all__ = ["CHECKS", "EQ27", "EQ27_CURRENT", "EXPERIMENTS", "PrintedEq27Task", "printed_eq27"]

RATE_TOLERANCE = 0.25
"""Relative tolerance on the predicted area-rate ratio 2(1 + R*²)."""
EQ27 = "iterative-smooth eq. 27 as printed"
"""Label of the run with CM01's eq. 27, constant, at the desired pose."""
EQ27_CURRENT = "iterative-smooth eq. 27 at current P"
"""Label of the run with eq. 27 re-evaluated at the current feature value."""


class PrintedEq27Task(VisualTask):
    """A visual task whose interaction matrix is a constant (k, 6) matrix (CM01 eq. 27).

    The features are measured as usual (by any sensor); :meth:`interaction` ignores the
    value, the depth and the depth error and returns ``L``, as a constant-matrix servo does.

    Args:
        task: The task to copy (terms, ``s*``, desired depth, combination matrix).
        L: (k, 6) the constant interaction matrix.
    """

    def __init__(self, task: VisualTask, L: FloatArray) -> None:
        super().__init__(
            task.terms, task.s_star, inv_depth_star=task.inv_depth_star, depth=task.depth, C=task.C
        )
        self.L = np.array(L, dtype=float)

    def interaction(
        self, s: FloatArray, inv_depth: Sequence[FloatArray], *, depth_scale: float = 1.0
    ) -> FloatArray:
        return self.L.copy()


def printed_eq27(exp: Experiment) -> None:
    """Give ``exp`` the same task with eq. 27 constant at ``P*`` (a run's setup)."""
    task = exp.task
    assert task.inv_depth_star is not None
    L_star = sphere_paper_interaction(task.s_star, task.inv_depth_star[0])
    exp.task = PrintedEq27Task(task, L_star)


RUNS = (
    RunSpec("classical", "classical"),
    RunSpec("iterative", "iterative"),
    RunSpec("iterative-smooth", "iterative-smooth"),
    RunSpec(EQ27, "iterative-smooth", setup=printed_eq27),
    RunSpec(EQ27_CURRENT, "iterative-smooth", overrides=('features[0].variant="paper"',)),
)

# --------------------------------------------------------------------------- checks

CHECKS: list[Check] = []
check = registrar(CHECKS)


@check(
    "positioned-no-limit",
    PAPER,
    "The sphere is positioned (centred, at the desired size) with no joint limit reached "
    "(iterative-smooth; iterative too), the avoidance constraining joints on the way",
    "CM01 §V-B1, Fig. 17",
)
def _positioned(runs: Runs) -> Verdict:
    exp = runs.experiments["iterative-smooth"]
    names = exp.robot.joint_names
    sm, it = runs["iterative-smooth"], runs["iterative"]
    constrained = [names[j] for j in np.flatnonzero(sm.log.constrained.max(axis=0) > 0)]
    ev = {
        "iterative-smooth": sm.outcome,
        "iterative-smooth iterations": sm.summary["iterations"],
        "iterative-smooth min margin": sm.summary["min_margin"],
        "iterative": it.outcome,
        "iterative min margin": it.summary["min_margin"],
        "required margin": SUCCESS_MARGIN,
        "joints in band at start": [names[j] for j in np.flatnonzero(exp.limits.in_band(exp.q0))],
        "joints constrained (iterative-smooth)": constrained,
    }
    return Verdict(succeeded(sm) and succeeded(it) and bool(constrained), ev)


@check(
    "eq27-printed-converges",
    PAPER,
    "With CM01's eq. 27 as printed (constant, at P*) the positioning converges too "
    "(iterative-smooth)",
    "CM01 §V-B1, eq. 27",
)
def _eq27(runs: Runs) -> Verdict:
    r = runs[EQ27]
    ev = {"outcome": r.outcome, "iterations": r.summary["iterations"]}
    ev["min margin"] = r.summary["min_margin"]
    return Verdict(succeeded(r), ev)


@check(
    "classical-reaches-a-limit",
    IMPL,
    "Set-up check: with nothing done (classical) a joint limit is reached, so the avoidance "
    "is needed (our scenario was chosen for it)",
)
def _classical(runs: Runs) -> Verdict:
    cl = runs["classical"]
    names = runs.experiments["classical"].robot.joint_names
    axis, it = hit(cl)
    ev = {
        "outcome": cl.outcome,
        "joint": None if axis is None else names[axis - 1],
        "iteration": it,
    }
    return Verdict(cl.outcome == "joint_limit", ev)


def _rates(runs: Runs, label: str) -> tuple[float, dict[str, Any]]:
    sm, r = runs["iterative-smooth"], runs[label]
    exp = runs.experiments["iterative-smooth"]
    r_exact = decay_rate(sm.log.t, sm.log.e[:, 2])
    r_27 = decay_rate(r.log.t, r.log.e[:, 2])
    predicted = 2.0 * (1.0 + float(exp.task.s_star[2]) / np.pi)
    ratio = r_27 / r_exact if np.isfinite(r_exact) and r_exact > 0 else float("nan")
    ev = {
        "area rate exact (1/s)": r_exact,
        "area rate eq. 27 (1/s)": r_27,
        "rate ratio eq. 27 / exact": ratio,
        "lambda (1/s)": exp.options.constant_lam,
        "predicted ratio 2(1 + R*²)": predicted,
    }
    return ratio / predicted, ev


@check(
    "eq27-printed-area-faster",
    IMPL,
    "With eq. 27 as printed the area converges faster than with the exact matrix by the "
    "factor 2(1 + R*²) of its area entry (R* the desired image radius)",
    "docs/formulas.md §3.3",
)
def _printed_rate(runs: Runs) -> Verdict:
    rel, ev = _rates(runs, EQ27)
    return Verdict(bool(np.isfinite(rel) and abs(rel - 1.0) <= RATE_TOLERANCE), ev)


@check(
    "eq27-current-converges-faster",
    IMPL,
    "With eq. 27 re-evaluated at the current P (our alternative) the task converges too, "
    "the area faster by about 2(1 + R*²)",
    "docs/formulas.md §3.3",
)
def _current_rate(runs: Runs) -> Verdict:
    rel, ev = _rates(runs, EQ27_CURRENT)
    ev["outcome"] = runs[EQ27_CURRENT].outcome
    ev["min margin"] = runs[EQ27_CURRENT].summary["min_margin"]
    ok = succeeded(runs[EQ27_CURRENT]) and bool(
        np.isfinite(rel) and abs(rel - 1.0) <= RATE_TOLERANCE
    )
    note = (
        "Rates are fitted on the whole run (1e-1 to 1e-4 of the start error), where the sphere "
        "is not yet centred and the re-evaluated matrix differs from its value at P*, so the "
        "ratio is a little below the prediction."
    )
    return Verdict(ok, ev, note)


# --------------------------------------------------------------------------- figures


def _plt() -> Any:
    from redservo.plots.style import _plt as plt

    return plt()


def _ellipse_pixels(s: FloatArray, camera: Any, n: int = 120) -> FloatArray:
    """(n, 2) pixel outline of the ellipse of a sphere with value ``s = (xc, yc, a)``."""
    from redservo.features import sphere_moments_from_area

    xc, yc, a = (float(v) for v in s[:3])
    n20, n11, n02 = sphere_moments_from_area(xc, yc, a)
    # A uniform ellipse with second moments N = [[n20, n11], [n11, n02]] is {p : p^T (4N)^-1 p <= 1}.
    L = np.linalg.cholesky(4.0 * np.array([[n20, n11], [n11, n02]]))
    ang = np.linspace(0.0, 2.0 * np.pi, n)
    pts = np.array([xc, yc]) + (L @ np.stack([np.cos(ang), np.sin(ang)])).T
    return np.asarray(camera.normalized_to_pixel(pts), dtype=float)


def _fig17(runs: Runs, out: Path) -> Path:
    from redservo.plots.style import save

    plt = _plt()
    main = "iterative-smooth"
    exp = runs.experiments[main]
    cam, log = exp.camera, runs[main].log
    names = exp.robot.joint_names
    fig = plt.figure(figsize=(11, 8))
    grid = fig.add_gridspec(3, 4, height_ratios=(1.4, 1.0, 1.0))
    ax = fig.add_subplot(grid[0, :2])
    for s, style, lab in (
        (log.s[0], "-", "initial"),
        (log.s[-1], "-", f"final (iteration {len(log) - 1})"),
        (exp.task.s_star, "--", "desired"),
    ):
        uv = _ellipse_pixels(np.asarray(s), cam)
        color = "k" if lab == "desired" else None
        ax.plot(uv[:, 0], uv[:, 1], style, lw=1.4, label=lab, color=color)
    centre = cam.normalized_to_pixel(log.s[:, :2])
    ax.plot(centre[:, 0], centre[:, 1], ":", color="0.4", lw=1.0, label="centre trajectory")
    ax.set_xlim(0, cam.width)
    ax.set_ylim(cam.height, 0)
    ax.set_aspect("equal")
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    ax.set_title(f"image of the sphere ({main})", fontsize=9)
    ax.legend(fontsize=7, loc="lower left")
    ax = fig.add_subplot(grid[0, 2:])
    labels = ("xc − xc*", "yc − yc*", "a − a*")
    for c in range(3):
        ax.plot(log.e[:, c], lw=1.3, label=f"{labels[c]} (exact L)")
    for label, style in ((EQ27, "--"), (EQ27_CURRENT, ":")):
        ax.plot(runs[label].log.e[:, 2], style, lw=1.3, label=f"a − a* ({label[17:]})")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("iteration")
    ax.set_title("error P − P* (normalized units)", fontsize=9)
    ax.legend(fontsize=7)
    for i, group in enumerate(("pelvis", "spine", "neck", "eyes")):
        ax = fig.add_subplot(grid[1 + i // 2, 2 * (i % 2) : 2 * (i % 2) + 2])
        group_panel(ax, np.arange(len(log), dtype=float), log.q_normalized, group, names)
        ax.set_xlabel("iteration", fontsize=8)
    fig.suptitle(
        "CM01 Fig. 17 — humanoid positioning wrt a sphere (iterative-smooth; normalized joints, "
        "dashed: thresholds at ±0.8)",
        fontsize=10,
    )
    return save(fig, out / "fig17_humanoid_sphere.png")


def _all_runs(runs: Runs, out: Path) -> Path:
    from redservo.plots.style import save

    plt = _plt()
    names = runs.base.robot.joint_names
    fig, axs = plt.subplots(len(GROUP_ORDER), 1, figsize=(7, 8), sharex=True)
    for ax, group in zip(axs, GROUP_ORDER, strict=True):
        for label, res in runs.results.items():
            qn = res.log.q_normalized
            j = max(JOINT_GROUPS[group], key=lambda k: float(np.max(np.abs(qn[:, k]))))
            ax.plot(qn[:, j], lw=1.1, label=f"{label}: {names[j]}")
        for y in (0.8, -0.8):
            ax.axhline(y, color="0.5", lw=0.8, ls="--")
        for y in (1.0, -1.0):
            ax.axhline(y, color="k", lw=0.8)
        ax.set_ylim(-1.08, 1.08)
        ax.set_ylabel(group, fontsize=9)
        ax.legend(fontsize=6, loc="best")
    axs[0].set_title("joint of each group nearest its limit, every run (normalized)", fontsize=9)
    axs[-1].set_xlabel("iteration")
    return save(fig, out / "humanoid_sphere_runs.png")


def figures(runs: Runs, out: Path) -> list[Path]:
    """Draw CM01 Figs. 16 and 17 and the joints of every run into ``out``."""
    return [
        fig16_humanoid_model(out / "fig16_humanoid_model.png"),
        _fig17(runs, out),
        _all_runs(runs, out),
    ]


EXPERIMENTS: tuple[ExperimentSpec, ...] = (
    ExperimentSpec(
        id="cm01-humanoid-sphere",
        title="CM01 §V-B1 — humanoid torso positioning wrt a sphere (Figs. 16-17)",
        paper="Chaumette & Marchand 2001, §V-B1, eq. 27, Figs. 16-17",
        scenario="cm01-humanoid-sphere",
        runs=RUNS,
        figures=figures,
        checks=tuple(CHECKS),
        notes=(
            "CM01 gives no numbers for the humanoid; the torso model, its ranges and the start "
            "are ours (see `redservo.robots.humanoid`, docs/formulas.md §11.4, Fig. 16 and the "
            "scenario file). The start (pelvis and spine in their bands) and the ball pose "
            "came from a random search for a case where classical reaches a limit and the "
            "iterative laws converge with both matrices. "
            f"`{EQ27}` uses CM01's eq. 27 as printed: the constant matrix at P* = (0, 0, πR*²) "
            f"and z_d. `{EQ27_CURRENT}` re-evaluates the same formula at the current P "
            "(set with `--set 'features[0].variant=\"paper\"'`), a documented alternative. "
            "Area rates are fitted slopes of ln|a − a*| (module docstring). λ = 0.5 1/s, "
            "dt = 40 ms."
        ),
    ),
)
