"""The pose-pair files of ``redservo calibrate-hand-eye``, read and validated.

JSON: a list (or ``{"pairs": [...]}``) of ``{"wMe": POSE, "cMo": POSE}`` where a POSE is a
4x4 nested list (a rigid transform, m) or ``{"translation": [x, y, z], "rotvec": [rx, ry,
rz]}`` (m, rad); or CSV with the header
``wMe_tx,wMe_ty,wMe_tz,wMe_rx,wMe_ry,wMe_rz,cMo_tx,cMo_ty,cMo_tz,cMo_rx,cMo_ry,cMo_rz``
(translations in m, rotation vectors in rad), one pair per row.

Every number must be finite; a translation at most :data:`MAX_TRANSLATION` m long (a robot
cell, not 1e308 m) and a rotation vector at most :data:`MAX_ROTVEC` rad. A bad file is one
:class:`~redservo.errors.ConfigurationError` naming the file and the entry
(``pairs[K].wMe.rotvec``, ``row K column wMe_tx``) and what is allowed.
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from redservo._validation import FloatArray, as_transform
from redservo.errors import ConfigurationError, RedservoError
from redservo.spatial import make_transform

__all__ = ["CSV_COLUMNS", "MAX_ROTVEC", "MAX_TRANSLATION", "load_pose_pairs"]

CSV_COLUMNS = tuple(
    f"{m}_{c}" for m in ("wMe", "cMo") for c in ("tx", "ty", "tz", "rx", "ry", "rz")
)
MAX_TRANSLATION = 100.0
"""Longest translation (m) of a pose in a pose file."""
MAX_ROTVEC = 4.0 * math.pi
"""Longest rotation vector (rad) of a pose in a pose file."""


def _vector(value: Any, where: str, unit: str, bound: float) -> FloatArray:
    """Three finite numbers (not strings or booleans), of norm at most ``bound``."""
    ok = isinstance(value, list | tuple) and len(value) == 3
    ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    if not ok:
        raise ConfigurationError(f"{where}: expected 3 numbers ({unit}), got {value!r:.80}")
    arr = np.array(value, dtype=float)
    if not (np.isfinite(arr).all() and np.abs(arr).max() <= bound) or np.linalg.norm(arr) > bound:
        raise ConfigurationError(
            f"{where}: must be finite and at most {bound:.4g} {unit} long, got {value!r:.80}"
        )
    return arr


def _checked(T: FloatArray, where: str) -> FloatArray:
    t = T[:3, 3]
    if not np.abs(t).max() <= MAX_TRANSLATION or np.linalg.norm(t) > MAX_TRANSLATION:
        shown = ", ".join(f"{v:.4g}" for v in t)
        raise ConfigurationError(
            f"{where}: the translation [{shown}] m is longer than {MAX_TRANSLATION:g} m"
        )
    return T


def _pose(value: Any, where: str) -> FloatArray:
    if isinstance(value, dict):
        unknown = set(value) - {"translation", "rotvec"}
        if unknown:
            raise ConfigurationError(
                f"{where}: unknown key(s) {sorted(unknown)}; allowed: translation, rotvec"
            )
        t = _vector(
            value.get("translation", [0.0, 0.0, 0.0]), f"{where}.translation", "m", MAX_TRANSLATION
        )
        r = _vector(value.get("rotvec", [0.0, 0.0, 0.0]), f"{where}.rotvec", "rad", MAX_ROTVEC)
        return make_transform(t=t, rotvec=r)
    rows = value if isinstance(value, list) and len(value) == 4 else None
    if rows is None or not all(
        isinstance(row, list)
        and len(row) == 4
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in row)
        for row in rows
    ):
        raise ConfigurationError(
            f"{where}: expected a 4x4 list of numbers or {{translation, rotvec}}, got {value!r:.80}"
        )
    return _checked(as_transform(np.array(rows, dtype=float), where), where)


def _csv(p: Path) -> tuple[list[FloatArray], list[FloatArray]]:
    wMe: list[FloatArray] = []
    cMo: list[FloatArray] = []
    with p.open(newline="") as fh:
        reader = csv.DictReader(fh)
        missing = [c for c in CSV_COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            raise ConfigurationError(f"missing column(s) {', '.join(missing)}")
        for k, row in enumerate(reader):
            try:
                v = [float(row[c]) for c in CSV_COLUMNS]
            except (TypeError, ValueError):
                raise ConfigurationError(f"row {k}: every column needs a number") from None
            for m, at in (("wMe", 0), ("cMo", 6)):
                where = f"row {k} {m}"
                t = _vector(v[at : at + 3], f"{where} translation", "m", MAX_TRANSLATION)
                r = _vector(v[at + 3 : at + 6], f"{where} rotvec", "rad", MAX_ROTVEC)
                (wMe if m == "wMe" else cMo).append(make_transform(t=t, rotvec=r))
    return wMe, cMo


def _json(p: Path) -> tuple[list[FloatArray], list[FloatArray]]:
    try:
        data = json.loads(p.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ConfigurationError(f"not valid JSON ({exc})") from None
    except RecursionError:
        raise ConfigurationError("the JSON is nested too deeply to be a pose file") from None
    pairs = data.get("pairs") if isinstance(data, dict) else data
    if not isinstance(pairs, list):
        raise ConfigurationError("expected a list of {wMe, cMo} pairs (or {pairs: [...]})")
    wMe: list[FloatArray] = []
    cMo: list[FloatArray] = []
    for k, pair in enumerate(pairs):
        if not isinstance(pair, dict) or {"wMe", "cMo"} - set(pair):
            raise ConfigurationError(f"pairs[{k}]: needs the keys wMe and cMo")
        wMe.append(_pose(pair["wMe"], f"pairs[{k}].wMe"))
        cMo.append(_pose(pair["cMo"], f"pairs[{k}].cMo"))
    return wMe, cMo


def load_pose_pairs(path: str | os.PathLike[str]) -> tuple[list[FloatArray], list[FloatArray]]:
    """``(wMe list, cMo list)`` from a JSON or CSV pose file (module docstring).

    Raises:
        ConfigurationError: missing file, bad format, a number that is not finite or not
            plausible; the message names the file and the entry (``pairs[K].wMe.rotvec``,
            ``row K wMe translation``) or the column.
    """
    p = Path(path)
    if not p.is_file():
        raise ConfigurationError(f"{p}: no such pose file", argument="poses")
    try:
        return _csv(p) if p.suffix.lower() == ".csv" else _json(p)
    except RedservoError as exc:
        raise ConfigurationError(f"{p}: {exc}", argument="poses") from None
    except OSError as exc:
        raise ConfigurationError(f"{p}: cannot read ({exc.strerror})", argument="poses") from None
