"""The Afma6 gantry robot of CM01's experiments, with the kinematic model of literature.md §F.

Joints (``Afma6.joint_names``): ``x, y, z`` are the gantry translations (m);
``A, B, C`` are the wrist rotations (rad). ``A`` turns about the base z axis,
and the last two wrist joints are mechanically coupled: the angle that enters
the model is ``C' = C - g B`` with ``g = 0.009091``; the wrist has a constant
offset ``L = -0.06924`` m. With ``c1, s1 = cos A, sin A``, ``c2, s2 = cos B, sin B``,
``c3, s3 = cos C', sin C'`` (literature.md §F, re-derived and checked against
finite differences in ``tests/test_robots.py``)::

    fRe = [[ s1 s2 c3 + c1 s3, -s1 s2 s3 + c1 c3, -s1 c2],
           [-c1 s2 c3 + s1 s3,  c1 s2 s3 + s1 c3,  c1 c2],
           [ c2 c3,            -c2 s3,             s2   ]]
    fte = (x + L c1, y + L s1, z)

The base-frame Jacobian ``fJe`` (ee-origin velocity and angular velocity, both
in the base frame) has linear rows ``[I3 | (-L s1, L c1, 0), 0, 0]`` and angular
columns ``A: (0, 0, 1)``, ``B: (c1 + g s1 c2, s1 - g c1 c2, -g s2)`` (the
``-g`` share of the C axis is the coupling), ``C: (-s1 c2, c1 c2, s2)``; then
``eJe = blkdiag(fRe^T, fRe^T) fJe``.

Choices (literature.md §F):

* Default joint limits: the older ViSP set (ViSP 3.5, the release Debian
  packages), ``joint_limits="visp3.5"``; the set updated in Sept. 2024 is
  available as ``joint_limits="visp2024"``. CM01's own 2001 limits are unknown.
* ``tool="ccmop"`` (default): the CCMOP camera, ``eMc`` with translation
  ``(0.0117, 0.0033, 0.2272)`` m and rotation vector ``θu = (1.231184,
  1.201529, 1.221731)`` rad; its optical axis is then close to ``x_e``, so at
  ``q = 0`` the camera looks along +z of the base frame. ``tool="generic"``:
  ``eMc = I``.
"""

from __future__ import annotations

import math
from typing import ClassVar, Final

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.errors import UnknownNameError
from redservo.robots.base import Robot
from redservo.robots.dh import check_q_named
from redservo.spatial import make_transform

__all__ = ["AFMA6_JOINT_LIMITS", "AFMA6_QDDOT_MAX", "AFMA6_QDOT_MAX", "AFMA6_TOOLS", "Afma6"]

AFMA6_QDOT_MAX: Final = (0.2, 0.2, 0.2, 0.7, 0.7, 0.7)
"""Velocity limits (m/s for x, y, z; rad/s for A, B, C). A documented choice: the Afma6's
datasheet is not public; these are the default velocity saturations of ViSP's robot
interface (0.2 m/s in translation, 0.7 rad/s in rotation), which ViSP applies to this robot."""
AFMA6_QDDOT_MAX: Final = (1.0, 1.0, 1.0, 3.0, 3.0, 3.0)
"""Acceleration limits (m/s², rad/s²). A documented choice (no public datasheet): the
gantry reaches its velocity limit in 0.2 s and the wrist in about 0.23 s."""

COUPLING: Final = 0.009091
"""Coupling between joints B and C: the model uses ``C' = C - COUPLING * B``."""
OFFSET: Final = -0.06924
"""Wrist offset ``L`` (m)."""

AFMA6_JOINT_LIMITS: Final[dict[str, tuple[tuple[float, ...], tuple[float, ...]]]] = {
    "visp3.5": (
        (-0.6501, -0.6001, -0.5001, -2.7301, -0.1001, -1.5901),
        (0.7001, 0.5201, 0.4601, 2.7301, 2.4801, 1.5901),
    ),
    "visp2024": (
        (-0.7501, -0.6501, -0.5001, -2.7301, -0.3001, -1.5901),
        (0.6001, 0.6701, 0.4601, 2.7301, 2.4801, 1.5901),
    ),
}
"""Named limit sets ``(q_min, q_max)`` (m, m, m, rad, rad, rad), literature.md §F."""

AFMA6_TOOLS: Final[dict[str, FloatArray]] = {
    "ccmop": make_transform(t=(0.0117, 0.0033, 0.2272), rotvec=(1.231184, 1.201529, 1.221731)),
    "generic": np.eye(4),
}
"""Named hand-eye transforms ``eMc`` (4x4), literature.md §F."""


class Afma6(Robot):
    """The 6-DOF Afma6 gantry (3 translations, 3 rotations) with an eye-in-hand camera.

    Args:
        tool: ``"ccmop"`` (default) or ``"generic"``: selects ``eMc`` (module docstring).
        joint_limits: ``"visp3.5"`` (default) or ``"visp2024"``.
        eMc: Explicit 4x4 hand-eye transform; overrides ``tool``.

    Raises:
        UnknownNameError: unknown ``tool`` or ``joint_limits`` name.
    """

    JOINT_NAMES: ClassVar[tuple[str, ...]] = ("x", "y", "z", "A", "B", "C")
    """Gantry x, y, z (m), then the wrist rotations A, B, C (rad)."""

    def __init__(
        self,
        *,
        tool: str = "ccmop",
        joint_limits: str = "visp3.5",
        eMc: ArrayLike | None = None,
    ) -> None:
        if tool not in AFMA6_TOOLS:
            raise UnknownNameError(
                f"unknown Afma6 tool {tool!r}; known tools: {', '.join(AFMA6_TOOLS)}"
            )
        if joint_limits not in AFMA6_JOINT_LIMITS:
            raise UnknownNameError(
                f"unknown Afma6 joint-limit set {joint_limits!r}; "
                f"known sets: {', '.join(AFMA6_JOINT_LIMITS)}"
            )
        q_min, q_max = AFMA6_JOINT_LIMITS[joint_limits]
        super().__init__(
            name="afma6",
            joint_names=self.JOINT_NAMES,
            joint_types=("prismatic",) * 3 + ("revolute",) * 3,
            q_min=q_min,
            q_max=q_max,
            eMc=AFMA6_TOOLS[tool].copy() if eMc is None else eMc,
            qdot_max=AFMA6_QDOT_MAX,
            qddot_max=AFMA6_QDDOT_MAX,
        )
        self.tool = tool if eMc is None else "custom"
        """The tool chosen at construction (``"custom"`` when ``eMc`` was given)."""

    def check_q(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``q`` as a (6,) array; a limit violation names the joint."""
        return check_q_named(self, q, check_limits)

    @staticmethod
    def _trig(q: FloatArray) -> tuple[float, float, float, float, float, float]:
        c3q = q[5] - COUPLING * q[4]
        return (
            math.cos(q[3]),
            math.sin(q[3]),
            math.cos(q[4]),
            math.sin(q[4]),
            math.cos(c3q),
            math.sin(c3q),
        )

    @staticmethod
    def _rotation(c1: float, s1: float, c2: float, s2: float, c3: float, s3: float) -> FloatArray:
        return np.array(
            [
                [s1 * s2 * c3 + c1 * s3, -s1 * s2 * s3 + c1 * c3, -s1 * c2],
                [-c1 * s2 * c3 + s1 * s3, c1 * s2 * s3 + s1 * c3, c1 * c2],
                [c2 * c3, -c2 * s3, s2],
            ]
        )

    def fkine_ee(self, q: FloatArray) -> FloatArray:
        """Return ``fMe`` (4x4) for a validated (6,) q (literature.md §F)."""
        c1, s1, c2, s2, c3, s3 = self._trig(q)
        T = np.eye(4)
        T[:3, :3] = self._rotation(c1, s1, c2, s2, c3, s3)
        T[0, 3] = q[0] + OFFSET * c1
        T[1, 3] = q[1] + OFFSET * s1
        T[2, 3] = q[2]
        return T

    def jacobe_base(self, q: FloatArray) -> FloatArray:
        """Return ``fJe`` (6, 6): ee-origin velocity and angular velocity in the base frame."""
        c1, s1, c2, s2, _, _ = self._trig(q)
        J = np.zeros((6, 6))
        J[0, 0] = J[1, 1] = J[2, 2] = 1.0
        J[0, 3] = -OFFSET * s1
        J[1, 3] = OFFSET * c1
        J[5, 3] = 1.0
        J[3:, 4] = (c1 + COUPLING * s1 * c2, s1 - COUPLING * c1 * c2, -COUPLING * s2)
        J[3:, 5] = (-s1 * c2, c1 * c2, s2)
        return J

    def jacobe(self, q: FloatArray) -> FloatArray:
        """Return ``eJe`` (6, 6) for a validated (6,) q: ``blkdiag(fRe^T, fRe^T) fJe``."""
        c1, s1, c2, s2, c3, s3 = self._trig(q)
        Rt = self._rotation(c1, s1, c2, s2, c3, s3).T
        fJe = self.jacobe_base(q)
        return np.vstack([Rt @ fJe[:3], Rt @ fJe[3:]])

    def kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """Return ``(fkine(q), jacobian(q))``, evaluating the trigonometry once (hot path)."""
        qa = self.check_q(q, check_limits=check_limits)
        c1, s1, c2, s2, c3, s3 = self._trig(qa)
        R = self._rotation(c1, s1, c2, s2, c3, s3)
        T = np.empty((4, 4))
        T[:3, :3] = R
        T[:3, 3] = (qa[0] + OFFSET * c1, qa[1] + OFFSET * s1, qa[2])
        T[3] = (0.0, 0.0, 0.0, 1.0)
        # eJe = blkdiag(R^T, R^T) fJe, written with the columns of fJe (literature.md §F).
        Rt = R.T
        eJe = np.zeros((6, 6))
        eJe[:3, :3] = Rt
        eJe[:3, 3] = Rt @ (-OFFSET * s1, OFFSET * c1, 0.0)
        eJe[3:, 3] = Rt[:, 2]
        eJe[3:, 4] = Rt @ (c1 + COUPLING * s1 * c2, s1 - COUPLING * c1 * c2, -COUPLING * s2)
        eJe[3:, 5] = Rt @ (-s1 * c2, c1 * c2, s2)
        return T @ self._eMc, self._cVe @ eJe
