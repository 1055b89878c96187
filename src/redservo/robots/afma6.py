"""The Afma6 gantry robot of CM01's experiments, with the kinematic model of docs/formulas.md §11.2.

Joints (``Afma6.joint_names``): ``x, y, z`` are the gantry translations (m);
``A, B, C`` are the wrist rotations (rad). ``A`` turns about the base z axis,
and the last two wrist joints are mechanically coupled: the angle that enters
the model is ``C' = C - g B`` with ``g = 0.009091``; the wrist has a constant
offset ``L = -0.06924`` m. With ``c1, s1 = cos A, sin A``, ``c2, s2 = cos B, sin B``,
``c3, s3 = cos C', sin C'`` (docs/formulas.md §11.2, re-derived and checked against
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

Choices (docs/formulas.md §11.2):

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
from typing import TYPE_CHECKING, Any, ClassVar, Final

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, is_float_vector
from redservo.errors import UnknownNameError
from redservo.kernels import lazy
from redservo.kernels.entry import Spares, entry_of, plain
from redservo.robots.base import Robot
from redservo.robots.dh import check_q_named
from redservo.robots.pack import RobotKind, RobotPack
from redservo.spatial import make_transform

__all__ = ["AFMA6_JOINT_LIMITS", "AFMA6_QDDOT_MAX", "AFMA6_QDOT_MAX", "AFMA6_TOOLS", "Afma6"]

AFMA6_QDOT_MAX: Final = (0.2, 0.2, 0.2, 0.7, 0.7, 0.7)
"""Velocity limits (m/s for x, y, z; rad/s for A, B, C). A documented choice: the Afma6's
datasheet is not public; these are the default velocity saturations of ViSP's robot
interface (0.2 m/s in translation, 0.7 rad/s in rotation), which ViSP applies to this robot."""
AFMA6_QDDOT_MAX: Final = (1.0, 1.0, 1.0, 3.0, 3.0, 3.0)
"""Acceleration limits (m/s², rad/s²). A documented choice (no public datasheet): the
gantry reaches its velocity limit in 0.2 s and the wrist in about 0.23 s."""

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import joint_check as _KJ
    from redservo.kernels import kinematics as _K
else:
    _K = lazy("kinematics")
    _KJ = lazy("joint_check")

COUPLING: Final = 0.009091
"""Coupling between joints B and C: the model uses ``C' = C - COUPLING * B``."""
OFFSET: Final = -0.06924
"""Wrist offset ``L`` (m)."""
_F64 = np.dtype(np.float64)

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
"""Named limit sets ``(q_min, q_max)`` (m, m, m, rad, rad, rad), docs/formulas.md §11.2."""

AFMA6_TOOLS: Final[dict[str, FloatArray]] = {
    "ccmop": make_transform(t=(0.0117, 0.0033, 0.2272), rotvec=(1.231184, 1.201529, 1.221731)),
    "generic": np.eye(4),
}
"""Named hand-eye transforms ``eMc`` (4x4), docs/formulas.md §11.2."""


class KinematicsEntry:
    """The entry point of a robot's kinematics kernel with what it was found for
    (:meth:`Afma6.kinematics`): the robot's limits and ``eMc`` objects and the arguments
    after ``q``."""

    __slots__ = ("args", "eMc", "entry", "limits", "spares")

    def __init__(self, entry: Any, limits: object, eMc: object, args: tuple[Any, ...]) -> None:
        self.entry, self.limits, self.eMc, self.args = entry, limits, eMc, args
        self.spares = Spares(((4, 4), (6, 6)))
        """The arrays the kernel writes ``bMc`` and ``J`` into (:mod:`redservo.kernels.entry`)."""

    def __reduce__(self) -> tuple[Any, ...]:
        """A pickled or copied robot forgets the entry (not picklable): its next call
        finds it again."""
        return (_forgotten, ())


def _forgotten() -> None:
    """What a pickled :class:`KinematicsEntry` becomes."""
    return None


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
    KIND: ClassVar[RobotKind] = RobotKind("afma6")
    """Its compiled kinematics (:mod:`redservo.robots.pack`)."""

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

    def fkine_ee(self, q: FloatArray) -> FloatArray:
        """Return ``fMe`` (4x4) for a validated (6,) q (docs/formulas.md §11.2)."""
        return np.asarray(_K.afma6_fkine_ee(np.ascontiguousarray(q), COUPLING, OFFSET))

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
        return np.asarray(_K.afma6_jacobe(np.ascontiguousarray(q), COUPLING, OFFSET))

    def fkine(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``bMc`` (4x4): the same kernel product as :meth:`kinematics`, bit for bit."""
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        return np.asarray(_K.matmul(_K.afma6_fkine_ee(qa, COUPLING, OFFSET), self._eMc))

    def jacobian(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``J(q) = cVe eJe`` (6, 6): the same kernel product as :meth:`kinematics`."""
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        return np.asarray(_K.matmul(self._cVe, _K.afma6_jacobe(qa, COUPLING, OFFSET)))

    def kernel_pack(self) -> RobotPack | None:
        """The Afma6 as the compiled engine takes it (:mod:`redservo.robots.pack`)."""
        if type(self).kinematics is not Afma6.kinematics:
            return None
        return self.KIND.pack(self._eMc, self._cVe, scalars=(COUPLING, OFFSET))

    def kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """Return ``(fkine(q), jacobian(q))`` in one kernel call (hot path; the products with
        ``eMc`` and ``cVe`` included). A C-contiguous float64 (6,) ``q`` strictly within its
        limits is checked inside the kernel (:func:`redservo.kernels.joint_check.afma6_checked`);
        anything else first gets :meth:`check_q`, which accepts it or names the joint."""
        hot = self.__dict__.get("_kin_entry")
        if (  # the set-up of an earlier call, a plain q: the kernel's entry (kernels/entry.py)
            hot is not None
            and check_limits is True
            and hot.limits is self._limits
            and hot.eMc is self._eMc
            and type(q) is np.ndarray
            and q.shape == (6,)
            and q.dtype == _F64
            and q.flags.carray
        ):
            out = hot.spares.take()
            if hot.entry(q, *hot.args, out):
                return out[0], out[1]  # a new tuple: the caller holds the arrays themselves
        elif is_float_vector(q, 6) and type(self).check_q is Afma6.check_q and _KJ.COMPILED:
            args = (self.q_min, self.q_max, bool(check_limits), self._eMc, self._cVe)
            out = (np.empty((4, 4)), np.empty((6, 6)))
            if _KJ.afma6_checked(q, *args, COUPLING, OFFSET, out):
                if check_limits is True and plain(q):
                    self._find_entry((q, *args, COUPLING, OFFSET, out))
                return out
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        bMc, J = _K.afma6_kinematics(qa, self._eMc, self._cVe, COUPLING, OFFSET)
        return bMc, J

    def _find_entry(self, args: tuple[object, ...]) -> None:
        """Keep the entry point of :func:`~redservo.kernels.joint_check.afma6_checked` for
        the types of ``args`` (a plain ``q``, this robot's limits and hand-eye arrays), with
        the limits and ``eMc`` it was found for: a later call with a plain ``q`` and the
        same limits and ``eMc`` objects calls it directly (the same machine code, without
        numba's typing of the arguments); anything else takes the dispatcher."""
        entry = entry_of(_KJ.afma6_checked, args)
        if entry is not None:
            self.__dict__["_kin_entry"] = KinematicsEntry(
                entry, self._limits, self._eMc, args[1:-1]
            )

    # -- viewer ---------------------------------------------------------------------------------

    def link_poses(self, q: ArrayLike, *, check_limits: bool = True) -> dict[str, FloatArray]:
        """Return the pose (4x4, m) of each moving part in the base frame (for the viewer).

        The gantry is drawn as its three carriages, each translated along its axis from
        the base origin, then the wrist: ``"A"`` (rotated about the base z axis by A, at
        the end of the z carriage), ``"B"`` (the wrist offset L along the rotated x axis)
        and ``"ee"`` (``fMe``, docs/formulas.md §11.2). The camera is ``fkine(q)``.

        Args:
            q: (6,) joint positions (m, m, m, rad, rad, rad).
            check_limits: Raise :class:`JointLimitError` if ``q`` is outside the limits.

        Returns:
            ``{"base", "x", "y", "z", "A", "B", "ee"}``, base to tip.
        """
        qa = self.check_q(q, check_limits=check_limits)
        x, y, z, a = (float(v) for v in qa[:4])
        ee = self.fkine_ee(qa)
        rz = np.array(
            [[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0, 0, 1]]
        )
        poses = {
            "base": np.eye(4),
            "x": make_transform(t=(x, 0.0, 0.0)),
            "y": make_transform(t=(x, y, 0.0)),
            "z": make_transform(t=(x, y, z)),
            "A": make_transform(rz, (x, y, z)),
            "B": make_transform(rz, ee[:3, 3]),
            "ee": ee,
        }
        return poses
