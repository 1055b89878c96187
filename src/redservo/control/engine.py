"""Which engine a :class:`~redservo.control.Controller` step runs on (module docstring of
:mod:`redservo.control.controller`, "Engines")."""

from __future__ import annotations

from typing import TYPE_CHECKING

from redservo.binding.control import CompiledControl, bind_controller
from redservo.errors import ConfigurationError

if TYPE_CHECKING:
    from redservo.control.controller import Controller

__all__ = ["bind_engine", "python_parts"]


def bind_engine(ctrl: Controller, engine: str) -> tuple[CompiledControl | None, str]:
    """The compiled engine of ``ctrl`` and ``""``, or None and the reason (one line) it is
    not used. ``engine``: ``"auto"``, ``"compiled"`` (an error when there is none) or
    ``"python"`` (the object path).

    Raises:
        ConfigurationError: ``engine`` is unknown, or ``"compiled"`` without a compiled
            engine for this set-up (``argument="engine"``, the reason in the message).
    """
    if engine not in ("auto", "compiled", "python"):
        raise ConfigurationError(
            f"engine must be 'auto', 'compiled' or 'python', got {engine!r}", argument="engine"
        )
    if engine == "python":
        return None, "engine='python' asked for"
    why = ""
    if ctrl.objectives:
        why = "objectives need the task state before the law"
    elif ctrl.feedforward == "estimated":
        why = "the estimated feed-forward needs the task state before the law"
    bound = why or bind_controller(
        ctrl.robot,
        ctrl.task,
        ctrl.law,
        ctrl.limits,
        lam=ctrl.lam,
        dt=ctrl.dt,
        depth_scale=ctrl.depth_scale,
    )
    if isinstance(bound, str):
        if engine == "compiled":
            raise ConfigurationError(f"no compiled engine: {bound}", argument="engine")
        return None, bound
    return bound, ""


def python_parts(ctrl: Controller) -> list[str]:
    """The parts of ``ctrl``'s step written in Python by a user (a law that is not a
    registered method, a task overriding its evaluation, an objective from outside
    redservo or a plain function): empty for the shipped parts, which are compiled kernels."""
    from redservo.control.objectives import CallableObjective
    from redservo.redundancy.base import Law, registered_methods

    parts = []
    law = ctrl.law
    if not isinstance(law, Law) or type(law) is not registered_methods().get(law.name):
        name = getattr(law, "name", None) or getattr(law, "__name__", type(law).__name__)
        parts.append(f"law {name!r}")
    if ctrl.task._custom:
        parts.append(f"task {type(ctrl.task).__name__}")
    parts += [
        f"objective {type(o).__name__}"
        for o in ctrl.objectives
        if isinstance(o, CallableObjective) or type(o).__module__.split(".")[0] != "redservo"
    ]
    return parts
