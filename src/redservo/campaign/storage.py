"""The rows of ``samples.csv``: columns, formatting, parsing and the resumable store."""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from redservo.campaign.definition import FORMAT_VERSION, CampaignDefinition
from redservo.campaign.sampling import Sample
from redservo.errors import ConfigurationError


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
        "limit_axis": int(hit["axis"]) + 1 if hit else None,
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
        "flags": "",
        "error": f"{type(exc).__name__}: {exc}",
    }


def _format(value: Any, kind: str) -> str:
    if value is None:
        return ""
    if kind == "float":
        return repr(float(value))  # shortest exact round trip
    if kind == "bool":
        return "True" if value else "False"
    return str(value)


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


class _Store:
    """``samples.csv`` plus ``definition.json`` in an output directory (append-only rows)."""

    def __init__(self, out: Path, defn: CampaignDefinition, seed: int) -> None:
        self.out = out
        self.columns = _columns(defn.nominal.joint_names)
        self.names = [c for c, _ in self.columns]
        self.csv = out / "samples.csv"
        meta_path = out / "definition.json"
        fp = defn.fingerprint(seed)
        out.mkdir(parents=True, exist_ok=True)
        if meta_path.exists():
            try:
                stored = json.loads(meta_path.read_text()).get("fingerprint")
            except (json.JSONDecodeError, AttributeError):
                stored = None
            if stored != fp:
                raise ConfigurationError(
                    f"{out} holds a campaign with another definition or seed (fingerprint "
                    f"{str(stored)[:12]} != {fp[:12]} for {defn.source} with seed {seed}); "
                    "use another output directory, or delete it to start over"
                )
        elif self.csv.exists():
            raise ConfigurationError(
                f"{self.csv} exists but {meta_path} does not: cannot tell which campaign the "
                "rows belong to; use another output directory, or delete it"
            )
        else:
            meta = {
                "fingerprint": fp,
                "seed": seed,
                "format": FORMAT_VERSION,
                "source": defn.source,
                "definition": defn.data,
                "scenario": defn.scenario.data,
            }
            meta_path.write_text(json.dumps(meta, indent=2, default=str) + "\n")
        self.rows = self._load()
        if not self.csv.exists():
            self.csv.write_text(",".join(self.names) + "\n")

    def _load(self) -> dict[tuple[int, str], dict[str, Any]]:
        rows: dict[tuple[int, str], dict[str, Any]] = {}
        if not self.csv.exists():
            return rows
        text = self.csv.read_text()
        reader = csv.reader(io.StringIO(text))
        header = next(reader, None)
        if header != self.names:
            raise ConfigurationError(
                f"{self.csv}: unexpected columns (written by another redservo version?); "
                "use another output directory, or delete it"
            )
        good = 0
        total = 0
        for fields in reader:
            total += 1
            row = self._parse_row(fields)
            if row is None:  # a line cut short by an interrupted write
                continue
            good += 1
            rows[(row["sample"], row["method"])] = row  # the last row of a pair wins
        if good != total:  # rewrite without the damaged lines
            self._rewrite(rows.values())
        return rows

    def _parse_row(self, fields: list[str]) -> dict[str, Any] | None:
        if len(fields) != len(self.columns):
            return None
        try:
            return {c: _parse(v, k) for (c, k), v in zip(self.columns, fields)}
        except ValueError:
            return None

    def _line(self, row: Mapping[str, Any]) -> str:
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(
            [_format(row.get(c), k) for c, k in self.columns]
        )
        return buf.getvalue()

    def _rewrite(self, rows: Iterable[Mapping[str, Any]]) -> None:
        tmp = self.csv.with_suffix(".csv.tmp")
        tmp.write_text(",".join(self.names) + "\n" + "".join(self._line(r) for r in rows))
        tmp.replace(self.csv)

    def normalize(self, row: Mapping[str, Any]) -> dict[str, Any]:
        """The row as it reads back from the file (so fresh and reused rows are identical)."""
        fields = next(csv.reader(io.StringIO(self._line(row))))
        parsed = self._parse_row(fields)
        assert parsed is not None
        return parsed

    def append(self, row: Mapping[str, Any]) -> None:
        with open(self.csv, "a", newline="") as fh:
            fh.write(self._line(row))
            fh.flush()
            os.fsync(fh.fileno())
