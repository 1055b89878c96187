"""Figures of runs and comparisons, in the house style of :mod:`redservo.plots.style`.

matplotlib is imported lazily (``pip install 'redservo[plot]'``). Every axis carries its
unit; titles name the scenario and the method(s). The style and file helpers
(:func:`savefig`, :func:`method_style`, :func:`figure_formats`, ...) live in
:mod:`redservo.plots.style` and are re-exported here.

Joint positions are plotted normalized to [-1, 1] (CM01's convention), with the
activation thresholds ``q̃`` (CM01 eq. 3) as dashed lines.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.plots.style import (
    FORMATS,
    METHOD_STYLES,
    ROLE_COLORS,
    _plt,
    clipped,
    figure_formats,
    method_style,
    parse_formats,
    place_legend,
    save,
    savefig,
)

if TYPE_CHECKING:  # pragma: no cover
    from redservo.experiment.build import Experiment
    from redservo.simulation import SimulationLog, SimulationResult

__all__ = [
    "FORMATS",
    "METHOD_STYLES",
    "FigureContext",
    "clipped",
    "compare_figures",
    "draw_compare",
    "draw_run",
    "figure_formats",
    "method_style",
    "parse_formats",
    "plot_image_trajectory",
    "plot_joints",
    "run_figures",
    "save",
    "savefig",
]


@dataclass(frozen=True)
class FigureContext:
    """What the figures of a run need besides its log.

    Attributes:
        scenario: Scenario name (titles).
        joint_names: Joint names, 0-based order.
        joint_units: ``"rad"`` or ``"m"`` per joint.
        rho: Band width of the thresholds (CM01 eq. 3).
        dt: Control period (s).
        camera: The camera (:class:`redservo.camera.Camera`), for the image plane.
        point_slices: (x, y) indices in ``s`` of each point feature.
        s_star: Desired features, or None.
    """

    scenario: str
    joint_names: tuple[str, ...]
    joint_units: tuple[str, ...]
    rho: float = 0.1
    dt: float | None = None
    camera: Any = None
    point_slices: tuple[tuple[int, int], ...] = ()
    s_star: FloatArray | None = None

    @classmethod
    def of(cls, exp: Experiment) -> FigureContext:
        """The context of an experiment."""
        from redservo.features import PointFeature

        slices, i = [], 0
        for term in exp.task.terms:
            if isinstance(term.feature, PointFeature):
                slices.append((i, i + 1))
            i += term.feature.size
        return cls(
            scenario=exp.scenario.name,
            joint_names=tuple(exp.robot.joint_names),
            joint_units=tuple("m" if t == "prismatic" else "rad" for t in exp.robot.joint_types),
            rho=exp.limits.rho,
            dt=exp.options.dt,
            camera=exp.camera,
            point_slices=tuple(slices),
            s_star=np.asarray(exp.task.s_star),
        )


def _xlabel(ctx: FigureContext | None) -> str:
    if ctx is not None and ctx.dt:
        return f"iteration (dt = {ctx.dt:g} s)"
    return "iteration (-)"


def _threshold(ax: Any, rho: float) -> None:
    for y in (1 - 2 * rho, -(1 - 2 * rho)):
        ax.axhline(y, color="0.5", lw=0.8, ls="--")
    for y in (1.0, -1.0):
        ax.axhline(y, color="k", lw=0.8)


def plot_joints(
    logs: Mapping[str, SimulationLog],
    axes: Sequence[int],
    path: Path,
    *,
    rho: float = 0.1,
    title: str = "",
    names: Sequence[str] | None = None,
    xlabel: str = "iteration (-)",
) -> Path:
    """Normalized positions of ``axes`` (0-based) vs iteration, one subplot per axis, one
    line per run (thresholds dashed, limits ±1 solid)."""
    plt = _plt()
    axes = list(axes)
    fig, axs = plt.subplots(
        len(axes), 1, figsize=(7, 1.6 * len(axes) + 0.9), sharex=True, squeeze=False
    )
    for ax, j in zip(axs[:, 0], axes, strict=True):
        for k, (label, log) in enumerate(logs.items()):
            ax.plot(log.q_normalized[:, j], label=label, lw=1.2, **method_style(label, k))
        _threshold(ax, rho)
        name = f"q{j}" if names is None else names[j]
        ax.set_ylabel(f"{name} (norm., -)", fontsize=8)
        ax.set_ylim(-1.08, 1.08)
    place_legend(axs[0, 0], outside=len(logs) > 1)
    axs[-1, 0].set_xlabel(xlabel)
    axs[0, 0].set_title(title or "normalized joint positions (±1 limits, dashed thresholds)")
    return save(fig, path)


def plot_series(
    logs: Mapping[str, SimulationLog],
    field: str,
    path: Path,
    *,
    components: Sequence[int] | None = None,
    labels: Sequence[str] | None = None,
    title: str = "",
    ylabel: str = "",
    xlabel: str = "iteration (-)",
) -> Path:
    """One subplot per run of a logged array (e.g. ``qdot``, ``camera_twist``) vs iteration."""
    plt = _plt()
    fig, axs = plt.subplots(len(logs), 1, figsize=(7, 2.3 * len(logs) + 0.4), squeeze=False)
    for ax, (name, log) in zip(axs[:, 0], logs.items(), strict=True):
        data = np.asarray(getattr(log, field))
        data = data[:, None] if data.ndim == 1 else data
        cols = range(data.shape[1]) if components is None else components
        for c in cols:
            ax.plot(data[:, c], lw=1.0, label=(labels[c] if labels else f"{field}[{c}]"))
        ax.set_title(f"{title} — {name}" if title else name, fontsize=9)
        ax.set_ylabel(ylabel)
        place_legend(ax, fontsize=6, ncol=3)
    axs[-1, 0].set_xlabel(xlabel)
    return save(fig, path)


def plot_error(
    logs: Mapping[str, SimulationLog],
    path: Path,
    *,
    title: str = "",
    xlabel: str = "iteration (-)",
) -> Path:
    """``‖e1‖`` (log scale) vs iteration, one line per run."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 3))
    for k, (name, log) in enumerate(logs.items()):
        ax.semilogy(np.maximum(log.error_norm, 1e-12), label=name, **method_style(name, k))
    ax.set_xlabel(xlabel)
    ax.set_ylabel("‖e1‖ (feature units)")
    ax.set_title(title or "task error")
    place_legend(ax)
    return save(fig, path)


def plot_image_trajectory(
    log: SimulationLog,
    path: Path,
    *,
    camera: Any,
    point_slices: Sequence[tuple[int, int]],
    s_star: FloatArray | None = None,
    title: str = "",
) -> Path:
    """Image-plane trajectories (pixels) of point features given by (x, y) index pairs in ``s``."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4.8))
    for ix, iy in point_slices:
        uv = camera.normalized_to_pixel(log.s[:, [ix, iy]])
        current = ROLE_COLORS["current"]
        ax.plot(uv[:, 0], uv[:, 1], lw=1.2, color=current)
        ax.plot(uv[0, 0], uv[0, 1], "o", mfc="none", color=current, ms=5)
        ax.plot(uv[-1, 0], uv[-1, 1], "s", color=current, ms=4)
        if s_star is not None:
            uvs = camera.normalized_to_pixel(s_star[[ix, iy]])
            ax.plot(uvs[0], uvs[1], "+", color=ROLE_COLORS["desired"], ms=10, mew=1.6)
    ax.set_xlim(0, camera.width)
    ax.set_ylim(camera.height, 0)
    ax.set_aspect("equal")
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    ax.set_title(title or "image trajectory (o start, □ end, + desired)", fontsize=9)
    return save(fig, path)


def _velocity_labels(ctx: FigureContext) -> list[str]:
    return [f"{n} ({u}/s)" for n, u in zip(ctx.joint_names, ctx.joint_units)]


def draw_run(log: SimulationLog, ctx: FigureContext, method: str, out: Path) -> list[Path]:
    """Figures of one run: joints, error, velocities, and the image for point features."""
    logs = {method: log}
    where = f"{ctx.scenario} [{method}]"
    x = _xlabel(ctx)
    units = set(ctx.joint_units)
    vunit = " or ".join(sorted(f"{u}/s" for u in units)) or "rad/s"
    paths = [
        *_joint_figures(logs, ctx, out, f"{where}:", vunit),
        plot_series(
            logs,
            "camera_twist",
            out / "camera_velocities.png",
            labels=("vx (m/s)", "vy (m/s)", "vz (m/s)", "ωx (rad/s)", "ωy (rad/s)", "ωz (rad/s)"),
            title=f"{ctx.scenario}: camera velocity (camera frame)",
            ylabel="v (m/s), ω (rad/s)",
            xlabel=x,
        ),
    ]
    if ctx.point_slices and ctx.camera is not None:
        paths.append(
            plot_image_trajectory(
                log,
                out / "image.png",
                camera=ctx.camera,
                point_slices=ctx.point_slices,
                s_star=ctx.s_star,
                title=f"{where}: image (o start, □ end, + desired)",
            )
        )
    return paths


def draw_compare(logs: Mapping[str, SimulationLog], ctx: FigureContext, out: Path) -> list[Path]:
    """Overlaid figures of several runs of one scenario."""
    where = f"{ctx.scenario}: {len(logs)} methods"
    return _joint_figures(logs, ctx, out, f"{where},", "rad/s or m/s")


def _joint_figures(
    logs: Mapping[str, SimulationLog], ctx: FigureContext, out: Path, where: str, vunit: str
) -> list[Path]:
    """The figures a run and a comparison share: normalized joint positions, task error and
    joint velocities (``vunit``, e.g. ``"rad/s"``), titled after ``where``."""
    x = _xlabel(ctx)
    return [
        plot_joints(
            logs,
            range(len(ctx.joint_names)),
            out / "joints.png",
            rho=ctx.rho,
            names=ctx.joint_names,
            title=f"{where} normalized joint positions",
            xlabel=x,
        ),
        plot_error(logs, out / "error.png", title=f"{where} task error", xlabel=x),
        plot_series(
            logs,
            "qdot",
            out / "joint_velocities.png",
            labels=_velocity_labels(ctx),
            title=f"{ctx.scenario}: joint velocities",
            ylabel=f"q̇ ({vunit})",
            xlabel=x,
        ),
    ]


def run_figures(result: SimulationResult, exp: Experiment, out: Path) -> list[Path]:
    """Figures of one run of ``exp`` (:func:`draw_run`)."""
    method = result.provenance.method if result.provenance is not None else exp.scenario.method
    return draw_run(result.log, FigureContext.of(exp), method, out)


def compare_figures(
    results: Mapping[str, SimulationResult], exp: Experiment, out: Path
) -> list[Path]:
    """Overlaid figures of several runs of one scenario (:func:`draw_compare`)."""
    return draw_compare({m: r.log for m, r in results.items()}, FigureContext.of(exp), out)
