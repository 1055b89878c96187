"""The redservo error hierarchy.

Every error raised on purpose by redservo derives from :class:`RedservoError`, so
``except redservo.RedservoError`` catches them all. Each message says what was
wrong and what is allowed. Numerical trouble during a servo (rank loss, more
critical axes than redundancy) is *not* an error: control laws degrade in a
documented way and report it in their diagnostics.
"""

from __future__ import annotations

__all__ = [
    "ConfigurationError",
    "GeometryError",
    "InfeasibleError",
    "JointLimitError",
    "RedservoError",
    "ScenarioError",
    "ShapeError",
    "UnknownNameError",
]


class RedservoError(Exception):
    """Base class of every error raised by redservo.

    Like pink's exceptions, ours carry their data as attributes so that a robot
    program can react without parsing the message: ``argument`` names the
    offending argument (or scenario key) when there is one.
    """

    def __init__(self, message: str = "", *, argument: str | None = None) -> None:
        super().__init__(message)
        self.argument = argument


class ShapeError(RedservoError, ValueError):
    """An array has the wrong shape, or holds NaN or inf."""


class JointLimitError(RedservoError, ValueError):
    """A joint configuration lies outside the robot's joint limits, or the limits are invalid.

    Attributes:
        joint: 0-based index of the first offending joint, or None.
        value: Its value (m or rad), or None.
        lower: Its lower limit (m or rad), or None.
        upper: Its upper limit (m or rad), or None.
    """

    def __init__(
        self,
        message: str = "",
        *,
        argument: str | None = None,
        joint: int | None = None,
        value: float | None = None,
        lower: float | None = None,
        upper: float | None = None,
    ) -> None:
        super().__init__(message, argument=argument)
        self.joint = joint
        self.value = value
        self.lower = lower
        self.upper = upper


class GeometryError(RedservoError, ValueError):
    """A geometric configuration is invalid or degenerate.

    Examples: a point at or behind the camera plane, a sphere or cylinder that
    contains the camera, a zero-length axis, a centrally symmetric point set for
    the moment features.
    """


class ConfigurationError(RedservoError, ValueError):
    """An option has an invalid value (negative gain, rho outside (0, 1/2), ...)."""


class UnknownNameError(RedservoError, KeyError):
    """An unknown method, robot, feature or scenario name."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it readable.
        return str(self.args[0]) if self.args else ""


class InfeasibleError(RedservoError, ValueError):
    """A constraint set has no solution (e.g. velocity bounds with lower > upper)."""


class ScenarioError(RedservoError, ValueError):
    """A scenario file is malformed; the message names the file and the key."""
