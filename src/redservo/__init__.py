"""redservo: redundancy-based joint-limit avoidance for visual servoing.

Implements Chaumette & Marchand 2001 (gradient projection, automatic gain and
the iterative null-space scheme), Mansard & Chaumette 2005 (directional
redundancy) and modern baselines behind one pure-function law interface.
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
from redservo.runs import Run, load_run

if TYPE_CHECKING:  # imported on first use by __getattr__ below
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
    "load_run",
    "make_law",
]


def __getattr__(name: str) -> Any:
    """``redservo.Controller`` on first use: it needs the robots, scene and task modules,
    which ``import redservo`` alone does not load."""
    if name == "Controller":
        from redservo.control import Controller

        return Controller
    raise AttributeError(f"module 'redservo' has no attribute {name!r}")
