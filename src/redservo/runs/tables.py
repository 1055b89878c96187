"""Tables of run summaries (markdown), shared by ``compare``, ``reproduce`` and ``campaign``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["summary_table"]


def _f(v: Any, fmt: str = ".3g") -> str:
    return "—" if v is None else format(v, fmt)


def summary_table(rows: Mapping[str, Mapping[str, Any]]) -> str:
    """Return a markdown table, one row per method, of the simulator summaries.

    Columns: outcome and success verdict (:func:`redservo.records.outcome_text`: why a run
    is no success, with the joint, 0-based, and iteration of a limit hit), iterations,
    minimum margin (fraction of the range), maximum joint speed (largest over axes, rad/s or
    m/s), maximum camera translation speed (m/s), maximum camera rotation speed (rad/s),
    discontinuity (max ‖Δq̇‖ per step).
    """
    from redservo.records.verdict import outcome_text

    head = (
        "| method | outcome and verdict | iterations | min margin | max joint speed | "
        "max cam. transl. (m/s) | max cam. rot. (rad/s) | discontinuity |\n"
        "|---|---|---:|---:|---:|---:|---:|---:|\n"
    )
    lines = []
    for name, s in rows.items():
        said = outcome_text(s)
        cam = s["max_camera_speed"]
        lines.append(
            f"| {name} | {said} | {s['iterations']} | {_f(s['min_margin'], '.3f')} | "
            f"{_f(max(s['max_joint_speed'] or [0.0]))} | {_f(cam['translation'])} | "
            f"{_f(cam['rotation'])} | {_f(s['discontinuity'])} |"
        )
    return head + "\n".join(lines)
