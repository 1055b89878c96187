"""redservo: redundancy-based joint-limit avoidance for visual servoing.

Implements Chaumette & Marchand 2001 (gradient projection, automatic gain and
the iterative null-space scheme), Mansard & Chaumette 2005 (directional
redundancy) and modern baselines behind one pure-function law interface.
"""

from __future__ import annotations

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

__all__ = [
    "METHODS",
    "METHOD_DESCRIPTIONS",
    "AdaptiveGain",
    "ConfigurationError",
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
