"""The registry of the reproduced experiments: one module per experiment group, in report order.

Its own small module so that the package (:func:`redservo.reproduction.reproduce`) and the
robustness sweep's workers (:mod:`redservo.reproduction.robustness`) both find the
experiments without importing each other. The experiment modules are imported when
:func:`experiments` is called, not when this module is.
"""

from __future__ import annotations

import importlib

from redservo.reproduction.base import ExperimentSpec

__all__ = ["experiments"]

_MODULES = (
    "cm01_gaze",
    "cm01_cylinder",
    "cm01_humanoid_sphere",
    "cm01_humanoid_tracking",
    "mc05_joint_limits",
    "mc05_optical_axis",
    "mc05_occlusion",
    "cross",
)


def experiments() -> dict[str, ExperimentSpec]:
    """Return the experiments ``{id: spec}`` in report order."""
    out: dict[str, ExperimentSpec] = {}
    for mod in _MODULES:
        module = importlib.import_module(f"redservo.reproduction.{mod}")
        for spec in module.EXPERIMENTS:
            out[spec.id] = spec
    return out
