"""Figures of runs and comparisons (matplotlib, imported lazily: ``pip install redservo[plot]``).

Every function writes PNG files and returns their paths. Joint positions are
plotted normalized to [-1, 1] (CM01's convention), with the activation
thresholds ``q̃`` drawn as dashed lines.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray

if TYPE_CHECKING:  # pragma: no cover
    from redservo.experiment import Experiment
    from redservo.simulation import SimulationLog, SimulationResult

__all__ = [
    "compare_figures",
    "plot_image_trajectory",
    "plot_joints",
    "run_figures",
    "save",
]


def _plt() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - optional dependency
        raise ImportError("figures need matplotlib: pip install 'redservo[plot]'") from exc
    return plt


def save(fig: Any, path: Path) -> Path:
    """Save ``fig`` to ``path`` (PNG, 120 dpi) and close it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    _plt().close(fig)
    return path


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
) -> Path:
    """Normalized positions of ``axes`` (0-based) vs iteration, one subplot per axis, one line per run."""
    plt = _plt()
    fig, axs = plt.subplots(len(axes), 1, figsize=(7, 2.2 * len(axes)), sharex=True, squeeze=False)
    for ax, j in zip(axs[:, 0], axes, strict=True):
        for label, log in logs.items():
            ax.plot(log.q_normalized[:, j], label=label, lw=1.2)
        _threshold(ax, rho)
        ax.set_ylabel(f"q{j + 1} (normalized)" if names is None else names[j])
        ax.set_ylim(-1.08, 1.08)
    axs[0, 0].legend(fontsize=7, loc="best")
    axs[-1, 0].set_xlabel("iteration")
    if title:
        axs[0, 0].set_title(title)
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
) -> Path:
    """One subplot per run of a logged array (e.g. ``qdot``, ``camera_twist``) vs iteration."""
    plt = _plt()
    fig, axs = plt.subplots(len(logs), 1, figsize=(7, 2.3 * len(logs)), squeeze=False)
    for ax, (name, log) in zip(axs[:, 0], logs.items(), strict=True):
        data = np.asarray(getattr(log, field))
        data = data[:, None] if data.ndim == 1 else data
        cols = range(data.shape[1]) if components is None else components
        for c in cols:
            ax.plot(data[:, c], lw=1.0, label=(labels[c] if labels else f"{field}[{c}]"))
        ax.set_title(f"{title} — {name}" if title else name, fontsize=9)
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=6, ncol=3, loc="best")
    axs[-1, 0].set_xlabel("iteration")
    return save(fig, path)


def plot_error(logs: Mapping[str, SimulationLog], path: Path, *, title: str = "") -> Path:
    """``‖e1‖`` (log scale) vs iteration, one line per run."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 3))
    for name, log in logs.items():
        ax.semilogy(np.maximum(log.error_norm, 1e-12), label=name)
    ax.set_xlabel("iteration")
    ax.set_ylabel("‖e1‖")
    ax.set_title(title)
    ax.legend(fontsize=7)
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
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for ix, iy in point_slices:
        uv = camera.normalized_to_pixel(log.s[:, [ix, iy]])
        ax.plot(uv[:, 0], uv[:, 1], lw=1.0)
        ax.plot(uv[0, 0], uv[0, 1], "o", color="tab:red", ms=4)
        ax.plot(uv[-1, 0], uv[-1, 1], "s", color="tab:green", ms=4)
        if s_star is not None:
            uvs = camera.normalized_to_pixel(s_star[[ix, iy]])
            ax.plot(uvs[0], uvs[1], "+", color="k", ms=10)
    ax.set_xlim(0, camera.width)
    ax.set_ylim(camera.height, 0)
    ax.set_aspect("equal")
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    ax.set_title(title or "image trajectory (o start, □ end, + desired)")
    return save(fig, path)


def _point_slices(exp: Experiment) -> list[tuple[int, int]]:
    from redservo.features import PointFeature

    out, i = [], 0
    for term in exp.task.terms:
        if isinstance(term.feature, PointFeature):
            out.append((i, i + 1))
        i += term.feature.size
    return out


def run_figures(result: SimulationResult, exp: Experiment, out: Path) -> list[Path]:
    """Figures of one run: joints, error, velocities, and the image for point features."""
    log = result.log
    logs = {exp.scenario.method: log}
    paths = [
        plot_joints(logs, range(exp.robot.n), out / "joints.png", rho=exp.limits.rho),
        plot_error(logs, out / "error.png"),
        plot_series(logs, "qdot", out / "joint_velocities.png", labels=exp.robot.joint_names),
        plot_series(
            logs,
            "camera_twist",
            out / "camera_velocities.png",
            labels=("vx", "vy", "vz", "wx", "wy", "wz"),
        ),
    ]
    slices = _point_slices(exp)
    if slices:
        paths.append(
            plot_image_trajectory(
                log,
                out / "image.png",
                camera=exp.camera,
                point_slices=slices,
                s_star=exp.task.s_star,
            )
        )
    return paths


def compare_figures(
    results: Mapping[str, SimulationResult], exp: Experiment, out: Path
) -> list[Path]:
    """Overlaid figures of several runs of one scenario."""
    logs = {name: r.log for name, r in results.items()}
    return [
        plot_joints(logs, range(exp.robot.n), out / "joints.png", rho=exp.limits.rho),
        plot_error(logs, out / "error.png"),
        plot_series(logs, "qdot", out / "joint_velocities.png", labels=exp.robot.joint_names),
    ]
