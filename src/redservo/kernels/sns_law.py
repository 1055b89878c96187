"""``sns`` as a law kernel of the step: its outputs repacked in the common layout.

:func:`redservo.kernels.sns.sns` returns its own tuple; :func:`sns_law` returns the common
``(q̇, iout, fout, axes, axf, vec)`` of :mod:`redservo.kernels.laws`, with the outputs that
``sns`` declares by name (``SaturationInNullSpace.KERNEL.outputs``: the restored flag and the
infeasible joint in ``iout``, the final clip in ``fout``) at the indices written there.
Units: rad or m, s.
"""

from __future__ import annotations

from typing import Any

from redservo.kernels._jit import kernel
from redservo.kernels.laws import F_SCALE, I_ITER, I_OVER, I_PROJ, I_RANK, new_outputs
from redservo.kernels.sns import sns

__all__ = ["sns_law"]

_I_RESTORED, _I_BAD, _F_CLIPPED = 5, 6, 3
"""As declared in ``SaturationInNullSpace.KERNEL.outputs`` (redundancy/sns.py)."""


@kernel
def sns_law(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
    sec: Any,
    has_sec: bool,
    v_opt: Any,
    has_v_opt: bool,
    a_opt: Any,
    has_a_opt: bool,
    margin: float,
    rcond: float,
    shield: bool,
) -> Any:
    """``sns`` (arguments as :func:`redservo.kernels.sns.sns`) with its outputs in the
    common layout: rank, free null-space dimension, iterations, scale < 1, restored,
    infeasible joint (-1: none), the task scale and the final clip."""
    rates = (v_opt, has_v_opt, a_opt, has_a_opt)
    out = sns(
        J1,
        e,
        q,
        lp,
        has_v,
        has_a,
        lam,
        dt,
        prev,
        has_prev,
        sec,
        has_sec,
        *rates,
        margin,
        rcond,
        shield,
    )
    n = q.shape[0]
    qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
    for i in range(n):
        qdot[i] = out[0][i]
        axes[i] = 1 if out[2][i] else 0
    iout[I_RANK] = out[7]
    iout[I_PROJ] = out[4]
    iout[I_ITER] = out[3]
    iout[I_OVER] = 1 if out[1] < 1.0 else 0
    iout[_I_RESTORED] = 1 if out[5] else 0
    iout[_I_BAD] = out[9]
    fout[F_SCALE] = out[1]
    fout[_F_CLIPPED] = out[6]
    return qdot, iout, fout, axes, axf, vec
