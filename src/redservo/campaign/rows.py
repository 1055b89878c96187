"""The columns of ``samples.csv``: one row per (sample, method), formatting and parsing.

Columns and their types (``int``, ``float``, ``str``, ``bool``, ``int?`` = optional integer)
are :func:`_columns`; ``reachable`` is ``True``/``False`` (the desired camera pose is
reachable within the success margin, :mod:`redservo.campaign.reach`) or empty (the task
gives no desired pose, or the sample could not be built); joint indices (``limit_axis``) are 0-based, like every joint index
redservo shows. Floats are written as the shortest exact repr, so a row reads back bit for
bit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from redservo.campaign.sampling import Sample

FAST_PATH = "compiled loop"
"""The ``_path`` note of a run on the compiled loop (any other note is the reason it fell back
to the object path); the job takes the note out of the row and counts it."""


def _columns(joint_names: Sequence[str]) -> list[tuple[str, str]]:
    """``(column, type)`` of ``samples.csv``; types: int, float, str, bool, int? (optional)."""
    xyz = ("x", "y", "z")
    return [
        ("sample", "int"),
        ("method", "str"),
        ("attempts", "int"),
        *((f"q0_{j}", "float") for j in joint_names),
        ("n_near", "int"),
        ("near_joints", "str"),
        *((f"target_t{a}", "float") for a in xyz),
        *((f"target_r{a}_deg", "float") for a in xyz),
        ("noise_std", "float"),
        ("noise_seed", "int"),
        ("depth_scale", "float"),
        *((f"hand_eye_t{a}", "float") for a in xyz),
        *((f"hand_eye_r{a}_deg", "float") for a in xyz),
        ("reachable", "str"),
        ("outcome", "str"),
        ("success", "bool"),
        ("iterations", "int"),
        ("limit_axis", "int?"),
        ("limit_joint", "str"),
        ("limit_iteration", "int?"),
        ("min_margin", "float"),
        ("max_joint_speed", "float"),
        ("max_cam_translation", "float"),
        ("max_cam_rotation", "float"),
        ("discontinuity", "float"),
        ("final_error", "float"),
        ("peak_velocity_ratio", "float"),
        ("velocity_violations", "int"),
        ("acceleration_violations", "int"),
        ("shield_activations", "int"),
        ("min_distance", "float"),
        ("flags", "str"),
        ("error", "str"),
    ]


def _sample_columns(s: Sample, joint_names: Sequence[str]) -> dict[str, Any]:
    xyz = ("x", "y", "z")
    row: dict[str, Any] = {"sample": s.number, "attempts": s.attempts}
    row.update({f"q0_{j}": float(v) for j, v in zip(joint_names, s.q0)})
    row["n_near"] = int(s.near.sum())
    row["near_joints"] = "+".join(j for j, b in zip(joint_names, s.near) if b)
    row.update({f"target_t{a}": float(v) for a, v in zip(xyz, s.translation)})
    row.update({f"target_r{a}_deg": float(v) for a, v in zip(xyz, s.rotation_deg)})
    row.update(noise_std=s.noise_std, noise_seed=s.noise_seed, depth_scale=s.depth_scale)
    row.update({f"hand_eye_t{a}": float(v) for a, v in zip(xyz, s.hand_eye_translation)})
    row.update({f"hand_eye_r{a}_deg": float(v) for a, v in zip(xyz, s.hand_eye_rotation_deg)})
    return row


def _summary_columns(summary: Mapping[str, Any], joint_names: Sequence[str]) -> dict[str, Any]:
    hit = summary.get("limit_hit")
    cam = summary["max_camera_speed"]
    return {
        "outcome": summary["outcome"],
        "success": bool(summary.get("success", summary["outcome"] == "converged")),
        "iterations": int(summary["iterations"]),
        "limit_axis": int(hit["axis"]) if hit else None,  # 0-based
        "limit_joint": joint_names[int(hit["axis"])] if hit else "",
        "limit_iteration": int(hit["iteration"]) if hit else None,
        "min_margin": float(summary["min_margin"]),
        "max_joint_speed": float(max(summary["max_joint_speed"] or [0.0])),
        "max_cam_translation": float(cam["translation"]),
        "max_cam_rotation": float(cam["rotation"]),
        "discontinuity": float(summary["discontinuity"]),
        "final_error": float(summary["final_error_norm"]),
        "peak_velocity_ratio": _nan_if_none(summary.get("peak_velocity_ratio")),
        "velocity_violations": int(summary.get("velocity_violations", 0)),
        "acceleration_violations": int(summary.get("acceleration_violations", 0)),
        "shield_activations": int(summary.get("shield_activations", 0)),
        "min_distance": _nan_if_none(summary.get("min_distance")),  # m, NaN: not measured
        "flags": ";".join(sorted(summary.get("flags", {}))),
        "error": "",
    }


def _nan_if_none(value: Any) -> float:
    return float("nan") if value is None else float(value)


def _error_columns(exc: BaseException) -> dict[str, Any]:
    nan = float("nan")
    return {
        "outcome": "error",
        "success": False,
        "iterations": 0,
        "limit_axis": None,
        "limit_joint": "",
        "limit_iteration": None,
        "min_margin": nan,
        "max_joint_speed": nan,
        "max_cam_translation": nan,
        "max_cam_rotation": nan,
        "discontinuity": nan,
        "final_error": nan,
        "peak_velocity_ratio": nan,
        "velocity_violations": 0,
        "acceleration_violations": 0,
        "shield_activations": 0,
        "min_distance": nan,
        "flags": "",
        "error": " ".join(f"{type(exc).__name__}: {exc}".split()),  # one line
    }


def _format(value: Any, kind: str) -> str:
    if value is None:
        return ""
    if kind == "float":
        return repr(float(value))  # shortest exact round trip
    if kind == "bool":
        return "True" if value else "False"
    return str(value)


def stored(columns: Sequence[tuple[str, str]], row: Mapping[str, Any]) -> dict[str, Any]:
    """The row as it reads back from its line (:func:`_format`, then :func:`_parse`),
    without writing it: what the campaign's statistics keep of a row just computed."""
    return {c: _stored_value(row.get(c), k) for c, k in columns}


def _stored_value(value: Any, kind: str) -> Any:
    """``_parse(_format(value, kind), kind)`` of a value a run's row holds (floats print
    as their shortest exact repr, so they read back as themselves)."""
    if kind == "float":
        return float(value)
    if kind == "int":
        return int(value)
    if kind == "int?":
        return None if value is None else int(value)
    if kind == "bool":
        return bool(value)
    return "" if value is None else str(value)


def _parse(text: str, kind: str) -> Any:
    if kind == "float":
        return float(text)
    if kind == "int":
        return int(text)
    if kind == "int?":
        return int(text) if text else None
    if kind == "bool":
        if text not in ("True", "False"):
            raise ValueError(f"not a boolean: {text!r}")
        return text == "True"
    return text
