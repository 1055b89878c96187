"""The law's side of the compiled campaign loop: its packed arguments, made once per method.

:func:`law_args` packs a law for :func:`redservo.campaign.loop_kernel.closed_loop`
(``(law_id, fopt, iopt, vopt, has_cap)``); :func:`method_law` keeps, per thread, each
campaign method's law object and its packed arguments per number of joints, so that the
runs of a campaign pack a method once, not once per run (the loop only reads them).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from redservo.errors import ConfigurationError
from redservo.redundancy import Law

__all__ = ["cached_law_args", "law_args", "method_law"]

_LAWS = threading.local()
"""Per thread: ``laws`` = {method key: (law, {n: packed arguments or None})}."""


def law_args(law: Law, n: int) -> tuple[Any, ...]:
    """``(law_id, fopt, iopt, vopt, has_cap)`` of the loop (:mod:`redservo.campaign.loop_kernel`)."""
    from redservo.campaign.loop_kernel import QP
    from redservo.redundancy.kio import law_options

    if law.name != "qp":
        o = law_options(law, n)
        return o.law_id, o.fopt, o.iopt, o.vopt, getattr(law, "alpha_max", None) is not None
    from redservo.redundancy.qp import ACTIVE_SET, BoundedLeastSquares, _v_per_joint

    assert isinstance(law, BoundedLeastSquares)
    v = law.v_max
    vopt = np.zeros((2, n))
    if v is not None:
        vopt[0] = _v_per_joint(v, n)
    fopt = np.array([law.rcond, law.eps, law.k_p, law.margin])
    in_kernel = law._resolve_backend() == ACTIVE_SET  # the solver runs in the loop
    iopt = np.array([int(law.shield), int(in_kernel), int(v is not None), 0], dtype=np.int64)
    return QP, fopt, iopt, vopt, False


def method_law(key: tuple[Any, ...], make: Callable[[], Law]) -> tuple[Law, dict[Any, Any]]:
    """The law of a campaign method (``key``: the method, its options and the scenario's
    control settings), made by ``make`` once per thread, with its cache of packed arguments
    by number of joints (:func:`cached_law_args`; the caller may keep other facts of the
    law there under keys that are not integers)."""
    laws: dict[tuple[Any, ...], Any] | None = getattr(_LAWS, "laws", None)
    if laws is None or len(laws) > 64:
        laws = _LAWS.laws = {}
    entry = laws.get(key)
    if entry is None:
        entry = laws[key] = (make(), {})
    out: tuple[Law, dict[Any, Any]] = entry
    return out


def cached_law_args(law: Law, n: int, cache: dict[Any, Any]) -> tuple[Any, ...] | None:
    """:func:`law_args` of a covered law for ``n`` joints, kept in ``cache``; None when its
    options raise :class:`ConfigurationError` (the object path then says so)."""
    if n not in cache:
        try:
            cache[n] = law_args(law, n)
        except ConfigurationError:
            cache[n] = None
    out: tuple[Any, ...] | None = cache[n]
    return out
