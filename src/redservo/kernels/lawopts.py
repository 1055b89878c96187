"""Where a law's options sit in the packs of the compiled step (no numba: importing is free).

:func:`redservo.kernels.step.law_step` takes a law's options as ``fopt`` (float64),
``iopt`` (int64) and ``vopt`` ((2, n) float64, per-joint rows, inf when absent). Each law
declares its options once (``Law.OPTIONS``, :class:`redservo.redundancy.options.Option`),
naming the slot below it is packed into; :func:`redservo.redundancy.kio.law_options` packs
from those declarations and :func:`redservo.kernels.step._raw_law` reads the same names.
"""

from __future__ import annotations

__all__ = ["NF", "NI"]

NF, NI = 8, 4
"""Sizes of ``fopt`` and ``iopt``."""

# common to every law
F_RCOND, F_ROBUST = 0, 1
"""rcond; the robust filter threshold ε of the task inverse (0 when ``robust`` is off)."""
I_SHIELD, I_FIRST = 0, 1
"""The position shield; secondary-first scaling."""

# gpm, gpm-auto
F_GAIN = 2
"""gpm: α. gpm-auto: α_max (inf: none)."""
I_CURRENT, I_AUTO_ROBUST = 2, 3
"""gpm-auto: the critical rule is "current"; the robust eq. 9."""

# iterative family (F_GAIN: α of the e2 term, 0 without it)
I_SMOOTH, I_LEVELS = 2, 3
"""Smooth γ weights; maximum number of levels (-1: none)."""
F_CON_RCOND, F_CON_FILTER = 3, 4
"""Cut-off and robust filter (0: off) of the constraint rows."""

# directional
F_KAPPA, F_DIR_MARGIN = 2, 3
I_JOINT_FORCE = 2
"""κ, the margin μ; the joint-limit force is on."""

# wln
I_HISTORY = 2
"""The paper's history rule."""

# sns
F_SNS_MARGIN = 2
I_HAS_V, I_HAS_A = 2, 3
V_VMAX, V_AMAX = 0, 1
"""The margin on the bounds; whether ``v_max``/``a_max`` are given; their rows of ``vopt``."""

# large-projection
F_E0, F_E1, F_RHO, F_RHO1, F_LAMBDA_TUNE, F_P_FILTER = 2, 3, 4, 5, 6, 7
I_PROJECTOR = 2
"""The switching thresholds, ρ, ρ1, λ_tune, the 1/|P_ii| filter (0: off); the projector."""
