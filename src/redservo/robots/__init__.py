"""Robot models with an eye-in-hand camera.

Every model is a :class:`Robot`: ``fkine(q)`` is the camera pose ``bMc`` and
``jacobian(q)`` the 6 x n ``J(q) = cVe · eJe(q)`` with ``v_c = J(q) q̇`` in the
camera frame (docs/formulas.md §1). Shipped models, by name for :func:`make_robot`:

* ``"afma6"`` — :class:`Afma6`, the 6-DOF gantry of CM01 (docs/formulas.md §11.2).
* ``"humanoid9"`` — :class:`Humanoid9`, CM01's 9-DOF virtual torso.
* ``"panda"`` — :class:`Panda`, the 7-DOF Franka Emika Panda.

:class:`DHRobot` builds any other serial arm from a Denavit–Hartenberg table, and
:class:`URDFRobot` reads one from a URDF file (extra ``redservo[urdf]``; imported on
first use, with :func:`shipped_urdf` for the shipped ``"panda"`` and ``"ur5e"`` files);
:class:`MJCFRobot` reads one from an MJCF file with MuJoCo (extra ``redservo[mujoco]``;
:func:`shipped_mjcf` for the trimmed MuJoCo Menagerie ``"panda"`` and ``"ur5e"``).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Final

from redservo.errors import ConfigurationError, UnknownNameError
from redservo.robots.afma6 import Afma6
from redservo.robots.base import JointType, Robot
from redservo.robots.dh import DHLink, DHRobot
from redservo.robots.eye_to_hand import EyeToHandRobot
from redservo.robots.humanoid import Humanoid9
from redservo.robots.panda import Panda

if TYPE_CHECKING:  # imported lazily by __getattr__ below
    from redservo.robots.mjcf import MJCFRobot, shipped_mjcf
    from redservo.robots.urdf import URDFRobot, shipped_urdf

__all__ = [
    "ROBOTS",
    "Afma6",
    "DHLink",
    "DHRobot",
    "EyeToHandRobot",
    "Humanoid9",
    "JointType",
    "MJCFRobot",
    "Panda",
    "Robot",
    "URDFRobot",
    "make_robot",
    "register_robot",
    "shipped_mjcf",
    "shipped_urdf",
]

_FACTORIES: Final[dict[str, Callable[..., Robot]]] = {
    "afma6": Afma6,
    "humanoid9": Humanoid9,
    "panda": Panda,
}

_LAZY: Final = {
    "URDFRobot": "redservo.robots.urdf",
    "shipped_urdf": "redservo.robots.urdf",
    "MJCFRobot": "redservo.robots.mjcf",
    "shipped_mjcf": "redservo.robots.mjcf",
}


def __getattr__(name: str) -> Any:
    """Import :class:`URDFRobot`, :class:`MJCFRobot` and their ``shipped_*`` on first access."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


ROBOTS: tuple[str, ...] = tuple(_FACTORIES)
"""Names accepted by :func:`make_robot` (and by a scenario's ``robot.model``)."""


def register_robot(name: str, factory: Callable[..., Robot]) -> None:
    """Make ``factory`` the robot model ``name`` of :func:`make_robot` and of a scenario's
    ``robot.model`` (a new robot kind: its module and this one line, docs/extending.md).

    Raises:
        ConfigurationError: ``name`` is not lower-case letters, digits, ``_`` and ``-``
            starting with a letter, or is already a model with another factory.
    """
    global ROBOTS
    if not (isinstance(name, str) and re.fullmatch(r"[a-z][a-z0-9_-]*", name)):
        raise ConfigurationError(
            f"register_robot: name {name!r}: allowed are lower-case letters, digits, '_' and"
            " '-', starting with a letter",
            argument="name",
        )
    if _FACTORIES.get(name, factory) is not factory:
        raise ConfigurationError(
            f"register_robot: robot {name!r} is already registered; known robots: "
            f"{', '.join(ROBOTS)}",
            argument="name",
        )
    _FACTORIES[name] = factory
    ROBOTS = tuple(_FACTORIES)


def make_robot(name: str, **options: Any) -> Robot:
    """Build a shipped robot model by name.

    Args:
        name: One of :data:`ROBOTS` (case-insensitive).
        **options: Keyword options of the model's constructor, e.g.
            ``make_robot("afma6", tool="generic")``.

    Raises:
        UnknownNameError: unknown robot name (the message lists the known ones),
            or an unknown named option value (e.g. an Afma6 tool).
        ConfigurationError: an option the model does not accept.
    """
    key = name.strip().lower() if isinstance(name, str) else name
    factory = _FACTORIES.get(key)
    if factory is None:
        raise UnknownNameError(f"unknown robot {name!r}; known robots: {', '.join(ROBOTS)}")
    try:
        return factory(**options)
    except TypeError as exc:
        raise ConfigurationError(f"invalid option for robot {key!r}: {exc}") from exc
