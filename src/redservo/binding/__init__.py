"""The binding: the one layer that knows both the public objects and the kernels.

Layers, bottom up (docs/architecture.md, checked by ``tests/test_layers.py``):

* :mod:`redservo.kernels` — array-only kernels; they import nothing of redservo outside
  :mod:`redservo.kernels`;
* the public objects (robots, features, scene, task, limits, laws) — they validate their
  inputs and call the kernels; :mod:`redservo.redundancy.packs` gives them the plain-array forms;
* this package — :mod:`redservo.binding.step` packs a whole set-up (robot, scene, task,
  law, limits) once into the arguments of one compiled step; nothing below it imports it.

:func:`compiled_step` and :func:`compiled_qp_step` are re-exported here.
"""

from __future__ import annotations

from redservo.binding.step import CompiledQPStep, CompiledStep, compiled_qp_step, compiled_step

__all__ = ["CompiledQPStep", "CompiledStep", "compiled_qp_step", "compiled_step"]
