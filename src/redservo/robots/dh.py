"""A generic serial robot described by Denavit–Hartenberg parameters.

Two conventions are supported (``convention=`` keyword of :class:`DHRobot`):

* ``"standard"`` (Denavit & Hartenberg 1955, as in Spong/Paul): the transform
  from frame i-1 to frame i is ``A_i = Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i)`` and
  joint i moves along/about ``z_{i-1}``.
* ``"modified"`` (Craig 1986; the Franka Emika documentation): ``A_i =
  Rx(α_i) Tx(a_i) Rz(θ_i) Tz(d_i)``, where ``a_i, α_i`` of row i are the
  distance and twist *before* joint i (Craig's ``a_{i-1}, α_{i-1}``), and joint
  i moves along/about ``z_i``.

Joint variables: for a revolute joint ``θ_i = theta_i + offset_i + q_i`` and
``d_i`` is constant; for a prismatic joint ``d_i = d_i + offset_i + q_i`` and
``θ_i`` is constant. ``q_min``/``q_max`` bound ``q_i`` (not ``q_i + offset_i``).

The end-effector pose is ``bMe = base · A_1 ⋯ A_n · flange`` and ``eJe`` is the
analytic geometric Jacobian: with ``z_j``, ``p_j`` the axis direction and a point
on the axis of joint j, and ``p_e`` the end-effector origin (all in the base
frame), column j is ``(z_j × (p_e - p_j), z_j)`` for a revolute joint and
``(z_j, 0)`` for a prismatic one, then rotated into the end-effector frame
(``eJe = blkdiag(bRe^T, bRe^T) · bJe``; rotating both factors of the cross
product first gives the same result with fewer operations).

Design choice: the last chain evaluation is cached (keyed on the exact bytes of
``q``), because a controller typically asks for ``fkine`` and ``jacobian`` at the
same configuration in each cycle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform, as_vector
from redservo.errors import ConfigurationError, JointLimitError, ShapeError
from redservo.kernels import lazy
from redservo.robots.base import JointType, Robot
from redservo.robots.pack import RobotKind, RobotPack

__all__ = ["DHConvention", "DHLink", "DHRobot"]

DHConvention = Literal["standard", "modified"]

_F64 = np.dtype(np.float64)
_LIMIT_TOL = 1e-9  # allowed excess beyond a limit, joint units (same as JointLimits.check)

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import joint_check as _KJ
    from redservo.kernels import kinematics as _K
else:
    _K = lazy("kinematics")
    _KJ = lazy("joint_check")


@dataclass(frozen=True, slots=True)
class DHLink:
    """One row of a Denavit–Hartenberg table (see the module docstring for the conventions).

    Attributes:
        a: Link length (m).
        alpha: Link twist (rad).
        d: Link offset (m); the constant part of ``d`` for a prismatic joint.
        theta: Joint angle (rad); the constant part of ``θ`` for a revolute joint.
        joint_type: ``"revolute"`` (default) or ``"prismatic"``.
        offset: Added to ``q`` before it enters ``θ`` (revolute, rad) or ``d``
            (prismatic, m): the joint reads zero where the table is evaluated at ``offset``.
        q_min: Lower limit of ``q`` (rad or m). Default for a revolute joint: -π.
            A prismatic joint must give both limits.
        q_max: Upper limit of ``q`` (rad or m). Default for a revolute joint: +π.
        name: Joint name (default ``"q<i>"``, 1-based).
    """

    a: float = 0.0
    alpha: float = 0.0
    d: float = 0.0
    theta: float = 0.0
    joint_type: JointType = "revolute"
    offset: float = 0.0
    q_min: float | None = None
    q_max: float | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        if self.joint_type not in ("revolute", "prismatic"):
            raise ConfigurationError(
                f"DHLink.joint_type must be 'revolute' or 'prismatic', got {self.joint_type!r}"
            )
        for field_name in ("a", "alpha", "d", "theta", "offset", "q_min", "q_max"):
            value = getattr(self, field_name)
            if value is None and field_name in ("q_min", "q_max"):
                continue
            if not isinstance(value, int | float | np.floating | np.integer) or not math.isfinite(
                value
            ):
                raise ShapeError(f"DHLink.{field_name} must be a finite number, got {value!r}")
        if self.joint_type == "prismatic" and (self.q_min is None or self.q_max is None):
            raise ConfigurationError(
                f"prismatic DH link {self.name or ''!r} needs explicit q_min and q_max (m)"
            )
        lo, hi = self.limits()
        if not hi > lo:
            raise JointLimitError(
                f"DH link {self.name or ''!r}: q_max ({hi:.6g}) must be strictly greater than "
                f"q_min ({lo:.6g})"
            )

    def limits(self) -> tuple[float, float]:
        """Return ``(q_min, q_max)`` with the revolute defaults (±π) applied."""
        lo = -math.pi if self.q_min is None else float(self.q_min)
        hi = math.pi if self.q_max is None else float(self.q_max)
        return lo, hi


def check_q_named(robot: Robot, q: ArrayLike, check_limits: bool) -> FloatArray:
    """Validate ``q`` for ``robot``; a limit violation names the joint (shared by the models).

    Raises:
        ShapeError: ``q`` is not a finite (n,) vector.
        JointLimitError: some ``q_i`` is outside ``[q_min,i, q_max,i]`` (beyond 1e-9).
    """
    if (
        type(q) is np.ndarray
        and q.dtype == _F64
        and q.shape == (robot.n,)
        and q.flags.c_contiguous
        and _KJ.COMPILED
    ):  # hot path: one compiled test accepts what the checks below accept, or defers to them
        if _KJ.joints_inside(q, robot.q_min, robot.q_max, bool(check_limits)):
            return q
    try:
        qa = as_vector(q, "q", robot.n)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ShapeError):
            raise
        # Ragged or non-numeric input: numpy cannot make a float vector of it.
        raise ShapeError(
            f"q must be a finite ({robot.n},) vector of numbers, got {q!r:.80}"
        ) from exc
    if check_limits:
        lo, hi = robot.q_min, robot.q_max
        # Hot path: every joint inside its limits, compared on Python floats (a few numpy
        # calls would cost microseconds per control period); the rest is checked below.
        for v, a, b in zip(qa.tolist(), lo.tolist(), hi.tolist(), strict=True):
            if not a <= v <= b:
                break
        else:
            return qa
        if float(np.minimum(qa - lo, hi - qa).min()) >= -_LIMIT_TOL:  # within the tolerance
            return qa
        out = np.flatnonzero((qa < lo - _LIMIT_TOL) | (qa > hi + _LIMIT_TOL))
        if out.size:
            i = int(out[0])
            unit = "m" if robot.joint_types[i] == "prismatic" else "rad"
            names = [robot.joint_names[int(k)] for k in out]
            raise JointLimitError(
                f"{robot.name}: joint {robot.joint_names[i]!r} (q[{i}]) = {qa[i]:.6g} {unit} is "
                f"outside its limits [{lo[i]:.6g}, {hi[i]:.6g}] {unit}; "
                f"{out.size} joint(s) out of range: {names}"
            )
    return qa


class DHRobot(Robot):
    """A serial chain of revolute/prismatic joints from a DH table, with an eye-in-hand camera.

    Describe your own arm in a few lines::

        >>> import numpy as np
        >>> from redservo.robots import DHLink, DHRobot
        >>> arm = DHRobot(
        ...     [
        ...         DHLink(d=0.3, alpha=np.pi / 2, q_min=-2.5, q_max=2.5, name="waist"),
        ...         DHLink(a=0.4, q_min=-1.5, q_max=1.5, name="shoulder"),
        ...         DHLink(a=0.3, q_min=-2.0, q_max=2.0, name="elbow"),
        ...         DHLink(joint_type="prismatic", q_min=0.0, q_max=0.1, name="slide"),
        ...     ],
        ...     convention="standard",
        ...     name="my_arm",
        ... )
        >>> arm.fkine_ee(np.zeros(4))[:3, 3].round(3).tolist()
        [0.7, 0.0, 0.3]
        >>> arm.jacobian([0.0, 0.2, -0.4, 0.05]).shape
        (6, 4)

    Args:
        links: The DH rows, base to tip.
        convention: ``"standard"`` or ``"modified"`` (module docstring).
        base: 4x4 pose of the DH frame 0 in the robot base frame (default identity).
        flange: 4x4 pose of the end-effector frame in the last DH frame (default identity).
        eMc: 4x4 camera pose in the end-effector frame (default identity).
        name: Model name.

    Raises:
        ConfigurationError: unknown convention, or no links.
        ShapeError: ``base``, ``flange`` or ``eMc`` is not a rigid transform.
    """

    KIND: ClassVar[RobotKind] = RobotKind("dh")
    """Its compiled kinematics (:mod:`redservo.robots.pack`)."""

    def __init__(
        self,
        links: Sequence[DHLink],
        *,
        convention: DHConvention = "standard",
        base: ArrayLike | None = None,
        flange: ArrayLike | None = None,
        eMc: ArrayLike | None = None,
        name: str = "dh",
        qdot_max: ArrayLike | None = None,
        qddot_max: ArrayLike | None = None,
    ) -> None:
        links = tuple(links)
        if not links:
            raise ConfigurationError("a DHRobot needs at least one link")
        if not all(isinstance(link, DHLink) for link in links):
            raise ConfigurationError("links must be DHLink instances")
        if convention not in ("standard", "modified"):
            raise ConfigurationError(
                f"convention must be 'standard' or 'modified', got {convention!r}"
            )
        lims = np.array([link.limits() for link in links])
        super().__init__(
            name=name,
            joint_names=[link.name or f"q{i + 1}" for i, link in enumerate(links)],
            joint_types=[link.joint_type for link in links],
            q_min=lims[:, 0],
            q_max=lims[:, 1],
            eMc=eMc,
            qdot_max=qdot_max,
            qddot_max=qddot_max,
        )
        self._links = links
        self._convention: DHConvention = convention
        self._base = np.eye(4) if base is None else as_transform(base, "base").copy()
        self._flange = np.eye(4) if flange is None else as_transform(flange, "flange").copy()
        self._tabulate(links)
        # (q bytes, (bMe, Z, P)) of the last evaluation; one attribute so that it is swapped atomically.
        self._cache: tuple[bytes, tuple[FloatArray, FloatArray, FloatArray]] | None = None

    def _tabulate(self, links: tuple[DHLink, ...]) -> None:
        """Store the constant per-link arrays the hot path does vectorized arithmetic on.

        ``_a`` and ``_d0`` (m), ``_theta0`` (rad), ``_offset`` (rad for a revolute joint, m
        for a prismatic one), the cosine and sine of each ``alpha`` (unitless), the revolute
        and prismatic masks (0/1), and ``_par``: the same table as the kernels take it
        (kernels/kinematics.py, rows ``DH_ROWS``).
        """
        alpha = np.array([link.alpha for link in links], dtype=float)
        self._a = np.array([link.a for link in links], dtype=float)
        self._ca = np.cos(alpha)
        self._sa = np.sin(alpha)
        self._d0 = np.array([link.d for link in links], dtype=float)
        self._theta0 = np.array([link.theta for link in links], dtype=float)
        self._offset = np.array([link.offset for link in links], dtype=float)
        self._revolute = np.array([link.joint_type == "revolute" for link in links])
        self._rev_f = self._revolute.astype(float)
        self._pri_f = 1.0 - self._rev_f
        self._par = np.ascontiguousarray(
            np.vstack(
                [
                    self._offset,
                    self._theta0,
                    self._d0,
                    self._a,
                    self._ca,
                    self._sa,
                    self._rev_f,
                    self._pri_f,
                ]
            )
        )

    # -- description ----------------------------------------------------------------------------

    @property
    def links(self) -> tuple[DHLink, ...]:
        """The DH rows, base to tip."""
        return self._links

    @property
    def convention(self) -> DHConvention:
        """``"standard"`` or ``"modified"``."""
        return self._convention

    @property
    def base(self) -> FloatArray:
        """4x4 pose of DH frame 0 in the base frame (a copy)."""
        return self._base.copy()

    @property
    def flange(self) -> FloatArray:
        """4x4 pose of the end-effector frame in the last DH frame (a copy)."""
        return self._flange.copy()

    def check_q(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``q`` as an (n,) array; a limit violation names the joint."""
        return check_q_named(self, q, check_limits)

    # -- kinematics -----------------------------------------------------------------------------

    def link_transforms(self, q: FloatArray) -> FloatArray:
        """Return the (n, 4, 4) stack of link transforms ``A_i(q_i)`` (module docstring)."""
        qa = np.ascontiguousarray(q, dtype=np.float64)
        return np.asarray(_K.dh_links(qa, self._par, self._convention == "standard"))

    def _chain(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Return ``(bMe, Z, P)``: ee pose, joint axes (n, 3) and points on them (n, 3), base frame."""
        key = q.tobytes()
        cache = self._cache
        if cache is not None and cache[0] == key:
            return cache[1]
        bMe, Z, P = _K.dh_chain(
            np.ascontiguousarray(q, dtype=np.float64),
            self._par,
            self._base,
            self._flange,
            self._convention == "standard",
        )
        out = (bMe, Z, P)
        self._cache = (key, out)
        return out

    def fkine_ee(self, q: FloatArray) -> FloatArray:
        """Return ``bMe`` (4x4), the end-effector pose in the base frame, for a validated (n,) q."""
        return self._chain(q)[0].copy()

    def jacobe(self, q: FloatArray) -> FloatArray:
        """Return the analytic ``eJe`` (6, n) for a validated (n,) q (module docstring)."""
        bMe, Z, P = self._chain(q)
        return np.asarray(_K.dh_jacobe(bMe, Z, P, self._par))

    def fkine(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``bMc`` (4x4): the same kernel product as :meth:`kinematics`, bit for bit."""
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        return np.asarray(_K.matmul(self._chain(qa)[0], self._eMc))

    def jacobian(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``J(q) = cVe eJe`` (6, n): the same kernel product as :meth:`kinematics`."""
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        return np.asarray(_K.matmul(self._cVe, self.jacobe(qa)))

    def kernel_pack(self) -> RobotPack | None:
        """The DH chain as the compiled engine takes it (:mod:`redservo.robots.pack`)."""
        if type(self).kinematics is not DHRobot.kinematics:
            return None
        standard = 1.0 if self._convention == "standard" else 0.0
        frames = np.stack((self._base, self._flange))
        return self.KIND.pack(
            self._eMc, self._cVe, scalars=(standard,), table=self._par, frames=frames
        )

    def kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """Return ``(fkine(q), jacobian(q))`` in one kernel call (the control hot path)."""
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        bMc, J = _K.dh_kinematics(
            qa,
            self._par,
            self._base,
            self._flange,
            self._convention == "standard",
            self._eMc,
            self._cVe,
        )
        return bMc, J

    # -- viewer ---------------------------------------------------------------------------------

    def link_poses(self, q: ArrayLike, *, check_limits: bool = True) -> dict[str, FloatArray]:
        """Return the pose (4x4, m) of every link frame in the base frame (for the viewer).

        Args:
            q: (n,) joint positions (m or rad).
            check_limits: Raise :class:`JointLimitError` if ``q`` is outside the limits.

        Returns:
            ``{"base": base, <joint i's name>: DH frame i (moved by joint i), ..., "ee":
            bMe}``, base to tip (n + 2 entries). The camera is ``fkine(q)``.
        """
        qa = self.check_q(q, check_limits=check_limits)
        out = {"base": self._base.copy()}
        M = self._base
        for name, Ai in zip(self.joint_names, self.link_transforms(qa)):
            M = M @ Ai
            out[name] = M
        out["ee"] = M @ self._flange
        return out
