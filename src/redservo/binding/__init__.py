"""The binding: the one layer that knows both the public objects and the kernels.

Layers, bottom up (docs/architecture.md, checked by ``tests/test_layers.py``):

* :mod:`redservo.kernels` — array-only kernels; they import nothing of redservo outside
  :mod:`redservo.kernels`;
* the public objects (robots, features, scene, task, limits, laws) — they validate their
  inputs and call the kernels; :mod:`redservo.redundancy.packs` gives them the plain-array forms;
* this package — :mod:`redservo.binding.control` packs a Controller's set-up (robot, task,
  law, limits) once into the arguments of the step kernel (:mod:`redservo.kernels.control`);
  :mod:`redservo.binding.packs` packs a scene and a task for the campaign loop's ideal
  sensor; nothing below it imports it.
"""

from __future__ import annotations
