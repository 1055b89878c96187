"""The tolerances of the velocity-damper rows, shared by the law objects and the compiled
loop (no numba: importing this is free).

:class:`~redservo.redundancy.distance_rows.DistanceRows` counts a row ``J_k q̇ ≥ b_k`` as met
when ``J_k q̇ ≥ b_k − ROW_TOL``; the compiled campaign loop
(:func:`redservo.kernels.loop_rows.rows_met`) asks :data:`SLACK` more before it keeps a step
in compiled code. Units: m/s.
"""

from __future__ import annotations

__all__ = ["ROW_TOL", "SLACK"]

ROW_TOL = 1e-9
"""m/s: a row counts as met when ``J_k q̇ ≥ b_k − 1e-9``."""
SLACK = 1e-12
"""m/s: the compiled loop keeps a step only when every row is met by ``ROW_TOL`` less this
(the rounding of ``J_k q̇`` is about 1e-16 m/s at workspace scale; numpy's product and the
loop's may differ in their last bits), else it hands the step to the law, which decides."""
