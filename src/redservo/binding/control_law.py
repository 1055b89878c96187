"""Which compiled Controller step a law has: its kernels, its packed options, or why none.

The laws of the step kernel's dispatch (:data:`redservo.kernels.step.LAW_IDS`) run in
:func:`redservo.kernels.control.robot_control` / ``measured_control`` with the options
packed by :func:`redservo.redundancy.kernel_call._law_pack`; a law with a compiled step of
its own declares it with a ``control_pack(n)`` method and an entry in :data:`_OWN_KERNELS`
(``qp``: :mod:`redservo.kernels.qp_control`, the same packs and buffer). Either way the
packed options are kept on the law until one of its options changes (:func:`stale`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from redservo.errors import ConfigurationError
from redservo.kernels import lazy
from redservo.redundancy.base import Law, law_class
from redservo.redundancy.kernel_call import _PACK, _law_pack
from redservo.redundancy.kio import law_options

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.binding.control import CompiledControl
    from redservo.kernels import control as _K
    from redservo.kernels import qp_control as _KQ
else:
    _K = lazy("control")
    _KQ = lazy("qp_control")

__all__ = ["control_kernels", "control_pack", "law_reason", "stale"]

Kernels = tuple[Callable[..., Any], Callable[..., Any]]
"""``(robot kernel, measured kernel)``: the step on the robot's compiled kinematics and the
step with the model Jacobian given (:mod:`redservo.kernels.control`'s signatures)."""

_OWN_KERNELS: dict[str, Callable[[], Kernels]] = {
    "qp": lambda: (_KQ.qp_robot_control, _KQ.qp_measured_control),
}
"""The laws with a compiled Controller step of their own (module docstring)."""


def control_kernels(law: Law) -> Kernels:
    """``(robot kernel, measured kernel)`` of ``law``'s compiled step (a law
    :func:`law_reason` accepts)."""
    own = _OWN_KERNELS.get(law.name)
    return own() if own is not None else (_K.robot_control, _K.measured_control)


def control_pack(law: Law, n: int) -> tuple[Any, ...]:
    """``law``'s options packed for its compiled step with ``n`` joints, kept on the law
    until one of its options is set (:func:`stale`).

    Raises:
        ConfigurationError: the law has no compiled step with these options.
    """
    own = getattr(law, "control_pack", None)
    if own is None or law.name not in _OWN_KERNELS:
        return _law_pack(law, n)
    hit = law.__dict__.get(_PACK)
    if hit is not None and hit[0] == n:
        return hit[1]
    pack = own(n)
    law.__dict__[_PACK] = (n, pack)
    return pack


def law_reason(law: object, n: int) -> str:
    """Why ``law`` has no compiled controller step for ``n`` joints (one line), or ``""``."""
    if not isinstance(law, Law):
        return f"the law is a Python callable ({type(law).__name__})"
    name = law.name
    if not hasattr(law, "diagnose") or type(law) is not law_class(name):
        return f"method {name!r} has no compiled controller step"
    if law.scaling != "uniform":
        return "secondary-first scaling runs on the Python step"
    try:
        if name in _OWN_KERNELS:
            control_pack(law, n)
        else:
            law_options(law, n)  # a compiled step for this law
    except ConfigurationError as err:
        return str(err)
    return ""


def stale(eng: CompiledControl) -> bool:
    """The law of ``eng`` changed an option since it was bound (``law.rcond = ...``,
    ``law.set_safety(...)``): ``eng`` packed the old ones, so the controller binds anew."""
    return eng.law.__dict__.get(_PACK) is not eng.law_token
