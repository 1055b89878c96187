"""The tolerances of the velocity-damper rows, shared by the law objects and the compiled
loop (no numba: importing this is free).

:class:`~redservo.redundancy.distance_rows.DistanceRows` counts a row ``J_k q̇ ≥ b_k`` as met
when ``J_k q̇ ≥ b_k − ROW_TOL``, and so does the one test both the law objects and the
compiled campaign loop call (:func:`redservo.kernels.loop_rows.rows_met`). Units: m/s.
"""

from __future__ import annotations

__all__ = ["ROW_TOL"]

ROW_TOL = 1e-9
"""m/s: a row counts as met when ``J_k q̇ ≥ b_k − 1e-9``."""
