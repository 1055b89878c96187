"""The visual-feature interface.

A feature holds its object's geometry in the object frame. Given the object's
pose ``cMo`` in the camera frame it returns its value ``s`` (k,) and the depth
information its interaction matrix needs. The interaction matrix ``L_s`` (k x 6)
satisfies ``ṡ = L_s v_c`` with ``v_c = (v, ω)`` the camera twist in the camera
frame (docs/formulas.md §1); normalized image coordinates throughout.

The depth information is a small vector of *inverse-depth parameters*: ``1/Z``
for a point; the plane coefficients ``(A, B, C)`` with ``1/Z = A x + B y + C``
for spheres and moments; ``(A, B, C)/D`` for lines and cylinders. All of them
scale as 1/distance, so a depth estimate ``Ẑ = (1 + ε) Z`` is modelled by
dividing them by ``1 + ε``, and the "desired" and "mean" depth options of a
task substitute or average them (see :mod:`redservo.task`).
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from redservo._validation import FloatArray

__all__ = ["Feature", "Measurement", "wrap_angle"]


class Measurement(NamedTuple):
    """A feature's value and the inverse-depth parameters of its interaction matrix."""

    s: FloatArray
    """(k,) feature value."""
    inv_depth: FloatArray
    """(p,) inverse-depth parameters (1/m), see the module docstring."""


def wrap_angle(a: FloatArray | float) -> FloatArray:
    """Wrap angles (rad) to (-π, π]."""
    out = np.pi - np.mod(np.pi - np.asarray(a, dtype=float), 2.0 * np.pi)
    return np.asarray(out)


class Feature(abc.ABC):
    """Base class of visual features.

    Subclasses set ``names`` (one per component) and ``angular`` (True for
    angle-valued components, whose errors are wrapped to (-π, π]).
    """

    names: tuple[str, ...] = ()
    angular: tuple[bool, ...] = ()

    @property
    def size(self) -> int:
        """Number of components k."""
        return len(self.names)

    @abc.abstractmethod
    def measure(self, cMo: FloatArray) -> Measurement:
        """Return the value and inverse-depth parameters for the object pose ``cMo`` (4x4).

        Raises:
            GeometryError: the object is not visible in a valid way (behind the
                camera, containing the camera, degenerate).
        """

    @abc.abstractmethod
    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        """Return the interaction matrix ``L_s`` (k, 6) at value ``s`` with the given depth."""

    def _measure_trusted(self, cMo: FloatArray) -> Measurement:
        """:meth:`measure` for a ``cMo`` the library built itself from validated transforms
        (a 4x4 float64 array, the task's hot path): the shipped features skip checking it
        again. The default calls :meth:`measure`."""
        return self.measure(cMo)

    def _trusted_measure(self) -> Callable[[FloatArray], Measurement]:
        """The function the task calls with its own ``cMo``: :meth:`_measure_trusted` when it
        was written next to this class's :meth:`measure` (so a subclass that overrides only
        :meth:`measure` keeps its override), :meth:`measure` otherwise."""
        cls = type(self)
        for klass in cls.__mro__:
            if "_measure_trusted" in vars(klass):
                if vars(klass).get("measure") is cls.measure:
                    return self._measure_trusted
                break
        return self.measure

    def value(self, cMo: FloatArray) -> FloatArray:
        """Return only ``s`` (k,)."""
        return self.measure(cMo).s

    def value_and_interaction(self, cMo: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Return ``(s, L_s)`` at the true pose ``cMo``."""
        m = self.measure(cMo)
        return m.s, self.interaction(m.s, m.inv_depth)

    def error(self, s: FloatArray, s_star: FloatArray) -> FloatArray:
        """Return ``s - s*`` (k,), with angle components wrapped to (-π, π]."""
        e = np.asarray(s, dtype=float) - np.asarray(s_star, dtype=float)
        if any(self.angular):
            mask = np.asarray(self.angular, dtype=bool)
            e = e.copy()
            e[mask] = wrap_angle(e[mask])
        return e
