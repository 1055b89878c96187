"""The control-law interface: a pure function of (J1, e1, q, limits, λ, dt, ...).

A law is called exactly as a real robot's controller would call it::

    law = redservo.make_law("iterative-smooth")
    res = law(J1=J1, e1=e1, q=q, limits=limits, lam=0.5, dt=0.04)
    robot.send_velocity(res.qdot)

Conventions (literature.md §0): ``e1 = C (s - s*)``, ``J1 = C L J(q)`` (m x n),
``ė1 = J1 q̇ + ∂e1/∂t``. Units: ``q̇`` in rad/s or m/s per axis, ``λ`` in 1/s,
``dt`` in s, ``e1`` in the task's units, ``de1_dt`` in task units per second.

Feed-forward (CM01 eq. 2): the primary motion is
``q̇1 = -λ J1^+ e1 - J1^+ ∂e1/∂t = -λ J1^+ (e1 + ∂e1/∂t / λ)``. Every law works
with the *effective error* ``e1 + ∂e1/∂t / λ`` so that the predictions of
CM01 eq. 8 include the feed-forward term (literature.md §D.3 item 10).

``secondary`` is an extra joint-space command (an artificial force, in joint
velocity units), projected by the law's own operator: ``J1^⊥`` for the
gradient-projection and iterative families, the non-linear directional
projector for ``directional``.
"""

from __future__ import annotations

import abc
import inspect
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, _to_float
from redservo.errors import ConfigurationError, JointLimitError, ShapeError, UnknownNameError
from redservo.limits import JointLimits
from redservo.redundancy.linalg import DEFAULT_RCOND

__all__ = [
    "Diagnostics",
    "Law",
    "LawInputs",
    "LawResult",
    "law_class",
    "make_law",
    "register",
    "registered_methods",
]


@dataclass(frozen=True, slots=True)
class Diagnostics:
    """What a law did in one call. Every field has a neutral default.

    Attributes:
        method: The law's name.
        task_rank: Numerical rank of ``J1``.
        rank_deficient: ``rank(J1) < m`` (rank loss; the law used the truncated pseudo-inverse).
        projector_rank: Rank of the operator applied to the secondary terms
            (``n - rank(J1)`` for ``J1^⊥``; the number of freed directions for
            ``directional``; 0 for ``classical``).
        critical: Axes constrained (stopped or slowed) at each level, level 1 first.
        iterations: Number of levels the iterative scheme solved.
        overconstrained: More constrained axes than available redundancy; the
            least-squares solution then no longer stops them all.
        alpha: Secondary gain α actually used (``gpm``, ``gpm-auto``, ``iterative-smooth-e2``).
        a: Gains on the null-space basis E (CM01 eqs. 10-15), ``a = a0 + F^⊥ b + ...``.
        b: Gains of the later levels, concatenated (CM01 eqs. 13-15, 18, 21).
        gamma: (n,) smoothing gains γ_k (CM01 eq. 17), for the constrained axes (0 elsewhere).
        scale: Task scale factor in [0, 1] (``sns``), 1 when the task is executed in full.
        notes: Free-text flags for unusual events (e.g. a degraded solve).
    """

    method: str
    task_rank: int = 0
    rank_deficient: bool = False
    projector_rank: int = 0
    critical: tuple[tuple[int, ...], ...] = ()
    iterations: int = 0
    overconstrained: bool = False
    alpha: float | None = None
    a: FloatArray | None = None
    b: FloatArray | None = None
    gamma: FloatArray | None = None
    scale: float | None = None
    notes: tuple[str, ...] = field(default=())

    @property
    def constrained_axes(self) -> tuple[int, ...]:
        """All axes constrained at any level, sorted."""
        return tuple(sorted({k for level in self.critical for k in level}))


class LawResult(NamedTuple):
    """The output of one control step."""

    qdot: FloatArray
    """(n,) joint velocity command (rad/s or m/s per axis)."""
    diagnostics: Diagnostics
    """What the law did, see :class:`Diagnostics`."""


class LawInputs(NamedTuple):
    """Validated inputs of one control step (internal to the laws)."""

    J1: FloatArray
    e1: FloatArray
    q: FloatArray
    limits: JointLimits
    lam: float
    dt: float
    de1_dt: FloatArray | None
    secondary: FloatArray | None

    @property
    def e_eff(self) -> FloatArray:
        """Effective error ``e1 + ∂e1/∂t / λ`` (feed-forward folded in, CM01 eq. 2)."""
        if self.de1_dt is None:
            return self.e1
        return self.e1 + self.de1_dt / self.lam


def _vec(value: ArrayLike, name: str, size: int) -> FloatArray:
    arr = (
        value
        if isinstance(value, np.ndarray) and value.dtype == np.float64
        else _to_float(value, name)
    )
    if arr.shape != (size,):
        raise ShapeError(f"{name} must have shape ({size},), got shape {arr.shape}")
    return arr


def _require_finite(**arrays: FloatArray | None) -> None:
    """Raise ShapeError naming the first array holding NaN or inf.

    One summed check on the hot path: a sum of finite numbers can only be
    non-finite by overflow (|values| ~ 1e308), which is then reported too.
    """
    total = 0.0
    for arr in arrays.values():
        if arr is not None:
            total += float(arr.sum())
    if math.isfinite(total):
        return
    for name, arr in arrays.items():
        if arr is not None and not np.isfinite(arr).all():
            raise ShapeError(f"{name} must be finite (no NaN or inf), got {arr}")
    raise ShapeError("inputs are too large (their sum overflows); rescale the task")


def validate_inputs(
    *,
    J1: ArrayLike,
    e1: ArrayLike,
    q: ArrayLike,
    limits: JointLimits,
    lam: float,
    dt: float,
    de1_dt: ArrayLike | None,
    secondary: ArrayLike | None,
) -> LawInputs:
    """Check shapes, finiteness, gains and that ``q`` lies within ``limits``."""
    J = J1 if isinstance(J1, np.ndarray) and J1.dtype == np.float64 else _to_float(J1, "J1")
    if J.ndim != 2 or J.shape[0] == 0:
        raise ShapeError(f"J1 must be a 2-D (m, n) array with m >= 1, got shape {J.shape}")
    m, n = J.shape
    if not isinstance(limits, JointLimits):
        raise ShapeError(
            f"limits must be a redservo.JointLimits, got {type(limits).__name__}; "
            "build one with JointLimits(q_min, q_max, rho=0.1)"
        )
    if limits.n != n:
        raise ShapeError(f"limits has {limits.n} joints but J1 has {n} columns")
    e = _vec(e1, "e1", m)
    qa = _vec(q, "q", n)
    ff = None if de1_dt is None else _vec(de1_dt, "de1_dt", m)
    sec = None if secondary is None else _vec(secondary, "secondary", n)
    _require_finite(J1=J, e1=e, q=qa, de1_dt=ff, secondary=sec)
    if float(np.minimum(qa - limits.q_min, limits.q_max - qa).min()) < -1e-9:
        limits.check(qa)  # raises JointLimitError with the details
        raise JointLimitError("q is outside the joint limits")  # pragma: no cover
    lam_f = float(lam)
    if not (math.isfinite(lam_f) and lam_f > 0.0):
        raise ConfigurationError(f"lam (λ, 1/s) must be a finite positive number, got {lam!r}")
    dt_f = float(dt)
    if not (math.isfinite(dt_f) and dt_f > 0.0):
        raise ConfigurationError(f"dt (control period, s) must be finite and positive, got {dt!r}")
    return LawInputs(J, e, qa, limits, lam_f, dt_f, ff, sec)


class Law(abc.ABC):
    """Base class of every control law.

    Subclasses set ``name`` and ``description``, take their options as
    keyword-only constructor arguments (validated there, raising
    :class:`~redservo.errors.ConfigurationError`), and implement
    :meth:`compute`. A law holds no state between calls unless ``stateful`` is
    True, in which case its docstring says what it remembers and :meth:`reset`
    clears it.
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    stateful: ClassVar[bool] = False

    def __init__(self, *, rcond: float = DEFAULT_RCOND) -> None:
        if not (0.0 < float(rcond) < 1.0):
            raise ConfigurationError(f"rcond must lie in (0, 1), got {rcond!r}")
        self.rcond = float(rcond)

    def __call__(
        self,
        *,
        J1: ArrayLike,
        e1: ArrayLike,
        q: ArrayLike,
        limits: JointLimits,
        lam: float,
        dt: float,
        de1_dt: ArrayLike | None = None,
        secondary: ArrayLike | None = None,
    ) -> LawResult:
        """Compute one joint-velocity command.

        Args:
            J1: (m, n) main-task Jacobian ``J1 = C L J(q)``.
            e1: (m,) main-task error ``e1 = C (s - s*)``.
            q: (n,) current joint positions (m or rad), within ``limits``.
            limits: The robot's :class:`~redservo.JointLimits`.
            lam: Gain λ > 0 (1/s).
            dt: Control period (s), used by the predictions of CM01 eq. 8.
            de1_dt: (m,) feed-forward ``∂e1/∂t`` for a moving target (CM01 eq. 2), or None.
            secondary: (n,) extra joint-space command, projected by the law's operator, or None.

        Returns:
            :class:`LawResult` with ``qdot`` (n,) and ``diagnostics``.

        Raises:
            ShapeError: wrong shapes, or NaN/inf inputs.
            JointLimitError: ``q`` outside ``limits``.
            ConfigurationError: ``lam`` or ``dt`` not positive.
        """
        x = validate_inputs(
            J1=J1, e1=e1, q=q, limits=limits, lam=lam, dt=dt, de1_dt=de1_dt, secondary=secondary
        )
        result = self.compute(x)
        qdot = result.qdot
        if not math.isfinite(float(qdot.sum())):  # never let a NaN velocity through
            qdot = np.zeros_like(qdot)
            d = result.diagnostics
            result = LawResult(
                qdot,
                Diagnostics(**{**_asdict(d), "notes": (*d.notes, "non-finite output zeroed")}),
            )
        return result

    @abc.abstractmethod
    def compute(self, x: LawInputs) -> LawResult:
        """Compute the command from validated inputs (implemented by each law)."""

    def reset(self) -> None:  # noqa: B027 - optional hook, stateless laws need nothing
        """Forget any state kept between calls (no-op for stateless laws)."""

    def __repr__(self) -> str:
        opts = ", ".join(
            f"{k}={v!r}" for k, v in sorted(vars(self).items()) if not k.startswith("_")
        )
        return f"make_law({self.name!r}{', ' if opts else ''}{opts})"


def _asdict(d: Diagnostics) -> dict[str, Any]:
    return {name: getattr(d, name) for name in Diagnostics.__slots__}


# -- registry ------------------------------------------------------------------------------------

_REGISTRY: dict[str, type[Law]] = {}
L = TypeVar("L", bound=type[Law])


def register(cls: L) -> L:
    """Class decorator: make a law available to :func:`make_law` under ``cls.name``."""
    if not cls.name:
        raise ConfigurationError(f"{cls.__name__} has no name")
    _REGISTRY[cls.name] = cls
    return cls


def registered_methods() -> dict[str, type[Law]]:
    """Return a copy of the name -> class registry."""
    return dict(_REGISTRY)


def law_class(name: str) -> type[Law]:
    """Return the law class registered as ``name``, or raise :class:`UnknownNameError`."""
    try:
        return _REGISTRY[name]
    except KeyError:
        known = ", ".join(_REGISTRY)
        raise UnknownNameError(f"unknown method {name!r}; known methods: {known}") from None


def make_law(name: str, **options: Any) -> Law:
    """Create the control law ``name`` with keyword ``options``.

    Args:
        name: One of :data:`redservo.METHODS`.
        **options: The law's keyword-only options (see its class docstring).

    Raises:
        UnknownNameError: ``name`` is not a known method.
        ConfigurationError: an option is unknown or has an invalid value.
    """
    cls = law_class(name)
    params = inspect.signature(cls.__init__).parameters
    allowed = [
        p for p in params if p != "self" and params[p].kind is inspect.Parameter.KEYWORD_ONLY
    ]
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ConfigurationError(
            f"method {name!r} has no option(s) {unknown}; its options are: {', '.join(allowed)}"
        )
    return cls(**options)
