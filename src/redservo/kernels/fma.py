"""Fused multiply-add, and the 3-vector products OpenBLAS computes with it, written out.

``np.dot`` of two 3-vectors and ``Rᵀ @ w`` of a 3x3 ``R`` are BLAS calls in compiled code
(``ddot``, ``dgemv``): about 50-100 ns each of call overhead for 5 or 15 floating-point
operations. The x86-64 kernels of OpenBLAS (the numpy and scipy wheels) compute them as
chains of fused multiply-adds from 0 (``dot = 0; dot += x[i] * y[i]``, contracted to one
rounding per term), so the written-out chains below give the very same bits where OpenBLAS
runs those kernels (tests/test_collision_fma.py compares them with ``np.dot`` on a million
random cases), and the same bits on every machine in compiled code.

:func:`fma` is ``round(a b + c)`` with one rounding: LLVM's ``llvm.fma.f64`` in compiled
code (one instruction on a CPU with FMA, libm's exact ``fma`` otherwise), an exact rational
computation on the reference path (``REDSERVO_NO_NUMBA``; Python 3.11 has no ``math.fma``).
On that path :data:`dot3`, :data:`sq3` and :data:`rtw3` are numpy's own products (the BLAS
calls the code made before, at their speed: an exact rational chain would cost 16 times
more per capsule/cylinder search), so the reference path keeps its previous numbers.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from redservo.kernels._jit import COMPILED, kernel

__all__ = ["dot3", "fma", "rtw3", "sq3"]


def _fma_exact(a: float, b: float, c: float) -> float:
    """``a b + c`` rounded once (IEEE 754 ``fusedMultiplyAdd``), by exact rationals."""
    p = a * b
    if not (abs(p) < float("inf") and abs(c) < float("inf")) or p != p:
        return p + c  # inf and nan: as the hardware (no finite exact value to round)
    exact = Fraction(a) * Fraction(b) + Fraction(c)
    if exact == 0:
        return p + c  # the sign of an exact zero: +0, or -0 when both terms are -0
    return float(exact)  # int / int in Python is correctly rounded


if COMPILED:
    from llvmlite import ir
    from numba import types
    from numba.core import cgutils
    from numba.extending import intrinsic

    def _fma_typer(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
        sig = types.float64(types.float64, types.float64, types.float64)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            fnty = ir.FunctionType(ir.DoubleType(), [ir.DoubleType()] * 3)
            fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.fma.f64")
            return builder.call(fn, args)

        return sig, codegen

    _llvm_fma: Any = intrinsic(_fma_typer)

    @kernel
    def fma(a: float, b: float, c: float) -> float:
        """``a b + c`` with one rounding (module docstring)."""
        return _llvm_fma(a, b, c)

else:
    fma = _fma_exact


@kernel
def _dot3_chain(x: Any, y: Any) -> float:
    return fma(x[2], y[2], fma(x[1], y[1], fma(x[0], y[0], 0.0)))


@kernel
def _sq3_chain(v0: float, v1: float, v2: float) -> float:
    return fma(v2, v2, fma(v1, v1, fma(v0, v0, 0.0)))


@kernel
def _rtw3_chain(R: Any, w0: float, w1: float, w2: float) -> tuple[float, float, float]:
    return (
        fma(R[2, 0], w2, fma(R[1, 0], w1, fma(R[0, 0], w0, 0.0))),
        fma(R[2, 1], w2, fma(R[1, 1], w1, fma(R[0, 1], w0, 0.0))),
        fma(R[2, 2], w2, fma(R[1, 2], w1, fma(R[0, 2], w0, 0.0))),
    )


def _dot3_blas(x: Any, y: Any) -> float:
    return float(np.dot(x, y))


def _sq3_blas(v0: float, v1: float, v2: float) -> float:
    v = np.array((v0, v1, v2))
    return float(np.dot(v, v))


def _rtw3_blas(R: Any, w0: float, w1: float, w2: float) -> tuple[float, float, float]:
    local = R.T @ np.array((w0, w1, w2))
    return float(local[0]), float(local[1]), float(local[2])


dot3: Any = _dot3_chain if COMPILED else _dot3_blas
"""``np.dot(x, y)`` of two 3-vectors, as OpenBLAS's ``ddot`` computes it."""
sq3: Any = _sq3_chain if COMPILED else _sq3_blas
"""``np.dot(v, v)`` of ``v = (v0, v1, v2)``, from scalars (:data:`dot3`)."""
rtw3: Any = _rtw3_chain if COMPILED else _rtw3_blas
"""``R.T @ w`` for a C-contiguous 3x3 ``R`` and ``w = (w0, w1, w2)``, a tuple of three
floats, as OpenBLAS's ``dgemv`` computes it."""
