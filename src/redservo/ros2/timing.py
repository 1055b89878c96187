"""The raw timing of a run on hardware (``timing.json``): loop period jitter, cycle time,
and the ages of the joint states at their arrival.

Jitter is measured on the loop's log: the differences of successive iteration times minus
the period (s); its p99 is of the absolute value. Units: seconds.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.hardware.recorder import ServoResult

__all__ = ["percentiles", "timing_report"]


def percentiles(values: Any, prefix: str) -> dict[str, float | None]:
    """``{prefix_p50, prefix_p99, prefix_max}`` of ``values`` (None when empty)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {f"{prefix}_p50": None, f"{prefix}_p99": None, f"{prefix}_max": None}
    return {
        f"{prefix}_p50": float(np.percentile(v, 50)),
        f"{prefix}_p99": float(np.percentile(v, 99)),
        f"{prefix}_max": float(v.max()),
    }


def timing_report(
    result: ServoResult, period: float, robot: Any, source: Any = None
) -> dict[str, Any]:
    """The timing of ``result``: period (s), jitter, cycle time, joint-state ages, and the
    camera's frames measured and skipped (a newer one had arrived while the tracker was busy)."""
    t = np.asarray(result.log.t, dtype=float)
    jitter = np.abs(np.diff(t) - period) if t.size > 1 else np.zeros(0)
    report: dict[str, Any] = {
        "period": period,
        "iterations": int(t.size),
        "overruns": result.summary.get("overruns"),
    }
    report.update(percentiles(jitter, "jitter"))
    report.update(percentiles(result.cycle_time, "cycle_time"))
    report.update(percentiles(getattr(robot, "ages", []), "joint_state_age"))
    if hasattr(source, "skipped"):
        report["frames"], report["frames_skipped"] = source.frames, source.skipped
    stamps = getattr(robot, "stamps", None)
    if stamps is not None:
        report["epoch_offset_uncertainty"] = stamps.uncertainty
    return report
