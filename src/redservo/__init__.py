"""redservo: redundancy-based joint-limit avoidance for visual servoing.

Implements Chaumette & Marchand 2001 (gradient projection, automatic gain and
the iterative null-space scheme), Mansard & Chaumette 2005 (directional
redundancy) and modern baselines behind one pure-function law interface.

Start here (:mod:`redservo.api`): :func:`load_scenario`, :func:`run`, :func:`compare`,
:func:`campaign`; :func:`load_run` reads a saved run; :class:`Controller` is the control
core for a loop of your own; :func:`make_law` builds a law by name (``METHODS``).

>>> import redservo
>>> result = redservo.run("afma6-gaze-demo")
>>> result.outcome, result.summary.success   # converged, and safe (docs/safety.md)
('converged', True)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from redservo._version import __version__
from redservo.errors import (
    ConfigurationError,
    GeometryError,
    InfeasibleError,
    JointLimitError,
    RedservoError,
    ScenarioError,
    ShapeError,
    UnknownNameError,
)
from redservo.limits import JointLimits
from redservo.redundancy import (
    METHOD_DESCRIPTIONS,
    METHODS,
    Diagnostics,
    Law,
    LawResult,
    make_law,
)
from redservo.redundancy.flags import Event, Flag
from redservo.redundancy.gain import AdaptiveGain
from redservo.runs.load import Run, load_run

if TYPE_CHECKING:  # imported on first use by __getattr__ below
    from redservo.api import compare, load_scenario, run
    from redservo.control import Controller

__all__ = [
    "METHODS",
    "METHOD_DESCRIPTIONS",
    "AdaptiveGain",
    "ConfigurationError",
    "Controller",
    "Diagnostics",
    "Event",
    "Flag",
    "GeometryError",
    "InfeasibleError",
    "JointLimitError",
    "JointLimits",
    "Law",
    "LawResult",
    "RedservoError",
    "Run",
    "ScenarioError",
    "ShapeError",
    "UnknownNameError",
    "__version__",
    "campaign",
    "compare",
    "load_run",
    "load_scenario",
    "make_law",
    "run",
]

_API = ("load_scenario", "run", "compare", "campaign")
"""The functions of :mod:`redservo.api`, imported on first use (``redservo.campaign`` is also
the campaign package, which is callable: it runs :func:`redservo.api.campaign`)."""


def __getattr__(name: str) -> Any:
    """``redservo.Controller`` and the :mod:`redservo.api` functions on first use: they need
    the robots, scene and task modules, which ``import redservo`` alone does not load."""
    if name == "Controller":
        from redservo.control import Controller

        return Controller
    if name == "campaign":
        import importlib

        # The callable package: importing it also sets it as this module's attribute.
        return importlib.import_module("redservo.campaign")
    if name in _API:
        from redservo import api

        return getattr(api, name)
    raise AttributeError(f"module 'redservo' has no attribute {name!r}")
