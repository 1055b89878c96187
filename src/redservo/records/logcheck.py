"""Check a saved run's ``log.npz`` before anything plots, animates or replays it (issue 32):
a truncated file, an array cut short (``q`` with 5 rows of 400), a wrong joint count or a
NaN where the servo never writes one is one :class:`~redservo.errors.ConfigurationError`
naming the file and the key, instead of a figure or an animation that says nothing.
"""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from redservo.errors import ConfigurationError

__all__ = ["check_log", "read_log"]

_PER_JOINT = ("q", "qdot", "q_normalized", "constrained", "gamma")
"""The arrays with one column a joint: (N, n)."""

_FINITE = ("t", "q", "qdot", "camera_twist")
"""The arrays the servo always fills with finite numbers (s, e, alpha, flags may hold NaN)."""


def read_log(path: Path) -> dict[str, np.ndarray]:
    """Every array of the ``log.npz`` at ``path``; a damaged or truncated file is a
    :class:`ConfigurationError` naming it."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: np.asarray(npz[k]) for k in npz.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as exc:
        raise ConfigurationError(
            f"{path}: damaged or truncated ({type(exc).__name__}: {exc}); re-run the scenario "
            "to write it again",
            argument="path",
        ) from None


def _fail(path: Path, key: str, what: str) -> ConfigurationError:
    return ConfigurationError(f"{path}: key {key!r} {what}", argument=key)


def check_log(path: Path, arrays: dict[str, Any], summary: dict[str, Any], n_joints: int) -> None:
    """Raise a :class:`ConfigurationError` naming ``path`` and the key when the log's arrays
    disagree with each other, with ``summary["iterations"]`` (when given) or with
    ``n_joints`` (the joint names'; 0 when unknown), or hold NaN/inf where the servo never
    writes one (:data:`_FINITE`)."""
    if "t" not in arrays:
        raise _fail(path, "t", "is missing (the times, s, one a servo iteration)")
    rows = int(np.shape(arrays["t"])[0]) if np.ndim(arrays["t"]) == 1 else -1
    if rows < 0:
        raise _fail(path, "t", f"has shape {np.shape(arrays['t'])}, expected (N,)")
    iterations = summary.get("iterations")
    if isinstance(iterations, int) and iterations != rows:
        raise _fail(path, "t", f"has {rows} rows but summary.json says {iterations} iterations")
    for key, value in arrays.items():
        shape = np.shape(value)
        if not shape or shape[0] != rows:
            raise _fail(path, key, f"has shape {shape}, expected {rows} rows (one an iteration)")
        if np.asarray(value).dtype.kind not in "biuf":
            raise _fail(path, key, f"holds {np.asarray(value).dtype} values, expected numbers")
        if key in _PER_JOINT and n_joints and (len(shape) != 2 or shape[1] != n_joints):
            raise _fail(path, key, f"has shape {shape}, expected ({rows}, {n_joints}) (joints)")
        if key in _FINITE and not np.all(np.isfinite(np.asarray(value, dtype=float))):
            raise _fail(path, key, "holds NaN or inf")
