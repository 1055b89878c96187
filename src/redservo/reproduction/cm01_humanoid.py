"""CM01 §V-B (Figs. 16-18): what the two humanoid experiments share, and Fig. 16.

The 9-DOF virtual humanoid torso (pelvis 3, spine 1, neck 3, eyes 2;
:mod:`redservo.robots.humanoid`, docs/formulas.md §11.4) carries the camera at the eyes.
CM01 gives its joints and says it was modelled with Denavit-Hartenberg parameters, but no
dimension or range: the geometry is ours, and Fig. 16 (:func:`fig16_humanoid_model`) says
so. The experiments are :mod:`~redservo.reproduction.cm01_humanoid_sphere` (§V-B1,
Fig. 17) and :mod:`~redservo.reproduction.cm01_humanoid_tracking` (§V-B2, Fig. 18).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.reproduction.metrics import decay_rate, first
from redservo.robots.humanoid import JOINT_GROUPS

__all__ = [
    "ACTIVATION",
    "GROUP_ORDER",
    "decay_rate",
    "fig16_humanoid_model",
    "group_activation",
    "group_panel",
    "group_speed_shares",
    "groups",
]

ACTIVATION = 0.25
"""Normalized displacement from the start at which a joint group counts as activated."""
GROUP_ORDER = ("eyes", "neck", "spine", "pelvis")
"""Joint groups, tip to base (the order of Fig. 18's panels)."""
_GROUP_COLORS = {
    "pelvis": "tab:blue",
    "spine": "tab:green",
    "neck": "tab:orange",
    "eyes": "tab:red",
}


def groups() -> dict[str, tuple[int, ...]]:
    """The joint indices of each group, in :data:`GROUP_ORDER`."""
    return {g: JOINT_GROUPS[g] for g in GROUP_ORDER}


def group_activation(
    q_normalized: ArrayLike,
    groups: Mapping[str, Sequence[int]],
    threshold: float = ACTIVATION,
) -> dict[str, int | None]:
    """Return, per group, the first iteration its normalized displacement reaches ``threshold``.

    Args:
        q_normalized: (N, n) normalized joint positions (-1 and +1 at the real limits).
        groups: Joint indices of each group.
        threshold: Activation level of ``max_{j in group} |q̃_j(k) - q̃_j(0)|``.

    Returns:
        ``{group: iteration or None}`` (None: never activated).
    """
    qn = np.asarray(q_normalized, dtype=float)
    disp = np.abs(qn - qn[:1])
    return {
        name: first(disp[:, list(idx)].max(axis=1) >= threshold) for name, idx in groups.items()
    }


def group_speed_shares(
    qdot: ArrayLike,
    joint_range: ArrayLike,
    groups: Mapping[str, Sequence[int]],
    start: int,
    stop: int,
) -> dict[str, float]:
    """Return, per group, the mean over iterations ``[start, stop)`` of its normalized speed.

    The normalized speed of a group at one iteration is ``max_{j in group} 2|q̇_j| / range_j``
    (1/s; ``q̃`` units per second). An empty window gives NaN for every group.

    Args:
        qdot: (N, n) joint velocities.
        joint_range: (n,) joint ranges ``q̄_max - q̄_min``.
        groups: Joint indices of each group.
        start: First iteration of the window.
        stop: One past the last iteration of the window.
    """
    v = 2.0 * np.abs(np.asarray(qdot, dtype=float)) / np.asarray(joint_range, dtype=float)
    lo, hi = max(int(start), 0), min(int(stop), v.shape[0])
    if hi <= lo:
        return {name: float("nan") for name in groups}
    return {name: float(v[lo:hi, list(idx)].max(axis=1).mean()) for name, idx in groups.items()}


def group_panel(
    ax: Any, t: FloatArray, qn: FloatArray, group: str, names: Sequence[str], *, legend: bool = True
) -> None:
    """Plot the normalized joints of one group, with the thresholds (±0.8) and limits (±1);
    ``legend=False``: the caller places the legend (after drawing the rest)."""
    for j in JOINT_GROUPS[group]:
        ax.plot(t, qn[:, j], lw=1.2, label=names[j])
    for y in (0.8, -0.8):
        ax.axhline(y, color="0.5", lw=0.8, ls="--")
    for y in (1.0, -1.0):
        ax.axhline(y, color="k", lw=0.8)
    ax.set_ylim(-1.08, 1.08)
    ax.set_ylabel(group, fontsize=9)
    if not legend:
        return
    from redservo.plots.style import place_legend

    place_legend(ax, fontsize=6, ncol=3)  # in a corner free of data, else outside


def _frames(robot: Any, q: FloatArray) -> FloatArray:
    """(n + 1, 4, 4) DH frames 0..n in the base frame (frame i-1 carries joint i's axis)."""
    M = robot.base
    out = [M]
    for Ai in robot.link_transforms(np.asarray(q, dtype=float)):
        M = M @ Ai
        out.append(M)
    return np.array(out)


def fig16_humanoid_model(path: Path, q: ArrayLike | None = None) -> Path:
    """CM01 Fig. 16: a 3-D line drawing of the torso, its joint axes and the camera frame.

    Draws the DH chain of :class:`~redservo.robots.humanoid.Humanoid9` at ``q`` (default
    the rest posture), the axis of every joint (colored by group, labelled), the legs from
    the hip centre to the floor for scale, and the camera's optical axis; the title says the
    geometry is ours.
    """
    from redservo.plots.style import _plt, save
    from redservo.robots.humanoid import HIP_HEIGHT, Humanoid9

    plt = _plt()
    robot = Humanoid9()
    qa = np.zeros(robot.n) if q is None else np.asarray(q, dtype=float)
    T = _frames(robot, qa)
    group_of = {j: g for g, idx in JOINT_GROUPS.items() for j in idx}
    fig = plt.figure(figsize=(7.5, 8.0))
    ax = fig.add_subplot(projection="3d")
    hip = robot.base[:3, 3]
    for side in (-0.1, 0.1):  # legs, for scale only (not part of the model)
        ax.plot([0, 0], [side, side * 0.6], [0, hip[2]], color="0.7", lw=2)
    origins = T[:, :3, 3]
    cam = robot.fkine(qa, check_limits=False)
    chain = np.vstack([origins, cam[:3, 3]])
    ax.plot(chain[:, 0], chain[:, 1], chain[:, 2], color="k", lw=2.5, label="links (DH chain)")
    length = 0.12
    for j in range(robot.n):
        z, p = T[j, :3, 2], T[j, :3, 3]
        seg = np.stack([p - length * z, p + length * z])
        color = _GROUP_COLORS[group_of[j]]
        ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color=color, lw=1.8)
        ax.text(*(p + length * z), f"{j + 1} {robot.joint_names[j]}", fontsize=6, color=color)
    c, zc = cam[:3, 3], cam[:3, 2]
    ax.plot(
        *np.stack([c, c + 0.35 * zc]).T, color="tab:purple", ls="--", lw=1.2, label="gaze (z_c)"
    )
    for g, color in _GROUP_COLORS.items():
        ax.plot([], [], color=color, lw=1.8, label=f"{g} joint axes")
    ax.set_xlim(-0.45, 0.45)
    ax.set_ylim(-0.45, 0.45)
    ax.set_zlim(0.0, 1.8)
    ax.set_box_aspect((0.9, 0.9, 1.8))
    ax.set_xlabel("x forward (m)")
    ax.set_ylabel("y left (m)")
    ax.set_zlabel("z up (m)")
    ax.view_init(elev=15, azim=-60)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title(
        "CM01 Fig. 16: humanoid model and its 9 DOF (pelvis 3, spine 1, neck 3, eyes 2).\n"
        "Our geometry (stature 1.75 m, hip at "
        f"{HIP_HEIGHT:.3f} H): CM01 gives no dimensions. redservo.robots.humanoid",
        fontsize=8,
    )
    return save(fig, path)
