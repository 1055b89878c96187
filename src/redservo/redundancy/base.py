"""The control-law interface: a pure function of (J1, e1, q, limits, λ, dt, ...).

A law is called exactly as a real robot's controller would call it::

    law = redservo.make_law("iterative-smooth")
    res = law(J1=J1, e1=e1, q=q, limits=limits, lam=0.5, dt=0.04)
    robot.send_velocity(res.qdot)

Conventions (docs/formulas.md §1): ``e1 = C (s - s*)``, ``J1 = C L J(q)`` (m x n),
``ė1 = J1 q̇ + ∂e1/∂t``. Units: ``q̇`` in rad/s or m/s per axis, ``λ`` in 1/s,
``dt`` in s, ``e1`` in the task's units, ``de1_dt`` in task units per second.

Feed-forward (CM01 eq. 2): the primary motion is
``q̇1 = -λ J1^+ e1 - J1^+ ∂e1/∂t = -λ J1^+ (e1 + ∂e1/∂t / λ)``. Every law works
with the *effective error* ``e1 + ∂e1/∂t / λ`` so that the predictions of
CM01 eq. 8 include the feed-forward term (docs/formulas.md §7.2).

``secondary`` is an extra joint-space command (an artificial force, in joint
velocity units), projected by the law's own operator: ``J1^⊥`` for the
gradient-projection and iterative families, the non-linear directional
projector for ``directional``.
"""

from __future__ import annotations

import abc
import inspect
import operator
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar, Literal, NamedTuple, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, UnknownNameError
from redservo.kernels.lawopts import F_ROBUST, I_FIRST, I_SHIELD
from redservo.limits import JointLimits
from redservo.redundancy import kernel_call as kc
from redservo.redundancy.flags import Event, Flag
from redservo.redundancy.gain import AdaptiveGain
from redservo.redundancy.inputs import LawInputs, validate_inputs
from redservo.redundancy.linalg import ROBUST_FILTER, TaskSVD, task_svd
from redservo.redundancy.options import (
    RCOND,
    Option,
    check_option,
    constructor,
    options_doc,
    safety_options,
)
from redservo.redundancy.safety import apply_safety

__all__ = [
    "RCOND",
    "SAFETY_OPTIONS",
    "Diagnostics",
    "Law",
    "LawInputs",
    "LawResult",
    "LazyDiagnostics",
    "law_class",
    "lazy_diagnostics",
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
        events: Typed flags for unusual events, each with a number attached
            (:class:`~redservo.redundancy.flags.Event`; e.g. a degraded solve, a scaled
            command, the shield acting). ``notes`` gives their messages.
        info: Informational lines that are not flags (the solver used, the directions a
            projector freed).
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
    events: tuple[Event, ...] = field(default=())
    info: tuple[str, ...] = field(default=())

    @property
    def notes(self) -> tuple[str, ...]:
        """The events' messages, then the informational ``info`` lines, in order."""
        return (*(e.message for e in self.events), *self.info)

    @property
    def flags(self) -> frozenset[Flag]:
        """The flags raised."""
        return frozenset(e.flag for e in self.events)

    def has(self, flag: Flag) -> bool:
        """True when ``flag`` was raised."""
        return any(e.flag is flag for e in self.events)

    def value(self, flag: Flag) -> float | None:
        """The number attached to ``flag`` (the first occurrence), or None if not raised."""
        for e in self.events:
            if e.flag is flag:
                return e.value
        return None

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


_new_result: Callable[[type[LawResult], tuple[object, ...]], LawResult] = tuple.__new__
"""``LawResult(qdot, diagnostics)`` without the keyword handling of its ``__new__`` (the
law call's hot path)."""


SAFETY_OPTIONS: tuple[str, ...] = ("shield", "robust", "scaling")
"""Options every law accepts through :func:`make_law` (see :class:`Law`)."""

Scaling = Literal["uniform", "secondary-first"]


class Law(abc.ABC):
    """Base class of every control law.

    Subclasses set ``name`` and ``description``, take their options as
    keyword-only constructor arguments (validated there, raising
    :class:`~redservo.errors.ConfigurationError`), and implement
    :meth:`compute`. A law holds no state between calls unless ``stateful`` is
    True, in which case its docstring says what it remembers and :meth:`reset`
    clears it.

    Every law also has the safety options (:data:`SAFETY_OPTIONS`, given to
    :func:`make_law` or set with :meth:`set_safety`; docs/safety.md):

    * ``shield`` (default True): the position shield of
      :mod:`redservo.redundancy.safety` keeps ``q + dt q̇`` within the limits less
      their margin, exactly in float64.
    * ``robust`` (default True): the paper laws invert ill-conditioned matrices with
      the bounded, filtered inverse (docs/safety.md); False runs them exactly as printed.
    * ``scaling`` (``"uniform"`` default, or ``"secondary-first"``): how a command is
      brought within the velocity and acceleration limits, which every law honours.
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    stateful: ClassVar[bool] = False
    OPTIONS: ClassVar[tuple[Option, ...]] = (RCOND,)
    """The law's options, declared once (:mod:`redservo.redundancy.options`): the
    constructor, its validation, ``repr`` and the compiled step's packing follow them."""
    shield: bool = True
    robust: bool = True
    scaling: Scaling = "uniform"
    rcond: float

    def __init__(self, **options: Any) -> None:
        declared = {o.name: o for o in type(self).OPTIONS}
        unknown = sorted(set(options) - set(declared))
        if unknown:
            raise ConfigurationError(
                f"method {self.name!r} has no option(s) {unknown}; its options are: "
                f"{', '.join(declared)}",
                argument=unknown[0],
            )
        for key, option in declared.items():
            value = options.get(key, option.default)
            setattr(self, key, check_option(option, value))
        self._setup()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Give a law without its own ``__init__`` a keyword-only constructor whose signature
        lists ``OPTIONS`` with their defaults (what :func:`make_law` and the docs read)."""
        super().__init_subclass__(**kwargs)
        if "__init__" not in cls.__dict__:  # a law with its own constructor keeps it
            cls.__init__ = constructor(cls, Law.__init__)  # type: ignore[method-assign]
            doc = cls.__dict__.get("__doc__")
            if doc:
                cls.__doc__ = doc.rstrip() + "\n" + options_doc(cls.OPTIONS) + "\n"

    def packed_extras(self) -> tuple[tuple[tuple[str, int], float], ...]:
        """What the compiled step takes besides the declared options, ``(slot, value)``
        (:mod:`redservo.kernels.lawopts`): the robust filter threshold, the shield,
        secondary-first scaling; laws add their own."""
        first = int(self.scaling == "secondary-first")
        return (
            (("f", F_ROBUST), self.filter_threshold),
            (("i", I_SHIELD), int(self.shield)),
            (("i", I_FIRST), first),
        )

    def __setattr__(self, name: str, value: Any) -> None:
        """Set an attribute; setting a public one (an option) drops the options packed for
        the step kernel (:mod:`redservo.redundancy.kernel_call`), so they are packed anew."""
        if not name.startswith("_"):
            self.__dict__.pop("_kernel_pack", None)
        object.__setattr__(self, name, value)

    @property
    def _kernel_step(self) -> bool:
        """True when this law's call runs through the step kernel
        (:mod:`redservo.redundancy.kernel_call`): a shipped law with a compiled step and a
        ``diagnose`` method, not a subclass (which may compute otherwise)."""
        cls = type(self)
        hit = _KERNEL_STEP.get(cls)
        if hit is None:
            from redservo.kernels.step import LAW_IDS

            hit = _KERNEL_STEP[cls] = (
                hasattr(cls, "diagnose")
                and cls.name in LAW_IDS
                and _REGISTRY.get(cls.name) is cls
                and "KERNEL" in cls.__dict__
            )
        return hit

    def _setup(self) -> None:  # noqa: B027 - optional hook
        """Checks across options and state, after the options are set (default: none)."""

    def set_safety(
        self,
        *,
        shield: bool | None = None,
        robust: bool | None = None,
        scaling: Scaling | None = None,
    ) -> Law:
        """Set the safety options (None keeps the current value), on this law and its inner
        laws (:meth:`_inner_laws`); return ``self``."""
        for key, value in safety_options(shield, robust, scaling).items():
            setattr(self, key, value)
        for inner in self._inner_laws():
            inner.set_safety(shield=shield, robust=robust, scaling=scaling)
        return self

    def _inner_laws(self) -> tuple[Law, ...]:
        """The laws this one calls for its commands (``predictive``'s fallback, ``qp-goal``'s
        ``qp``): :meth:`set_safety` sets theirs too (default: none)."""
        return ()

    def __call__(
        self,
        *,
        J1: ArrayLike,
        e1: ArrayLike,
        q: ArrayLike,
        limits: JointLimits,
        lam: float | AdaptiveGain,
        dt: float,
        de1_dt: ArrayLike | None = None,
        secondary: ArrayLike | None = None,
        qdot_prev: ArrayLike | None = None,
    ) -> LawResult:
        """Compute one joint-velocity command.

        Args:
            J1: (m, n) main-task Jacobian ``J1 = C L J(q)``.
            e1: (m,) main-task error ``e1 = C (s - s*)``.
            q: (n,) current joint positions (m or rad), within ``limits``.
            limits: The robot's :class:`~redservo.JointLimits` (positions, and optionally
                velocity and acceleration limits and the shield's margin).
            lam: Gain λ > 0 (1/s), or an :class:`~redservo.AdaptiveGain` λ(‖e1‖∞).
            dt: Control period (s), used by the predictions of CM01 eq. 8 and the limits.
            de1_dt: (m,) feed-forward ``∂e1/∂t`` for a moving target (CM01 eq. 2), or None.
            secondary: (n,) extra joint-space command, projected by the law's operator, or None.
            qdot_prev: (n,) the previous command (rad/s or m/s), needed by the acceleration
                limits; None (first call) leaves them out.

        Returns:
            :class:`LawResult` with ``qdot`` (n,) and ``diagnostics``. ``qdot`` never
            exceeds ``limits.qdot_max``, never holds NaN, and with ``shield`` on keeps
            ``q + dt·qdot`` within the limits less their margin. A law with a compiled
            step builds its diagnostics when they are first read
            (:class:`LazyDiagnostics`), from what the call computed.

        Inputs with the signature the compiled step takes (C-contiguous float64 arrays of
        matching shapes, a float or adaptive gain, a float ``dt``) have their values checked
        by the kernel alone; a call with the signature of the previous one (the same limits
        object and options, arrays of the same shapes and layouts, float gains) only has
        its inputs' metadata looked at. Anything else, or a value the kernel refuses, gets
        the full checks below, which name the argument.

        Raises:
            ShapeError: wrong shapes, complex values, or NaN/inf inputs.
            JointLimitError: ``q`` outside ``limits``.
            ConfigurationError: ``lam`` or ``dt`` not a finite positive number.
        """
        seen = None  # the signature of the law's last call (kernel_call.quick)
        if de1_dt is None and secondary is None:
            seen = kc.quick(self, J1, e1, q, limits, lam, dt, qdot_prev)
            if type(seen) is tuple:  # the result, its diagnostics built when read
                diagnostics = _NEW_LAZY(LazyDiagnostics)
                _SET_BUILD(diagnostics, (kc.diagnose, seen[1]))
                return _new_result(LawResult, (seen[0], diagnostics))
        kernel = self.scaling == "uniform" and self._kernel_step
        if kernel and seen is None:  # a checked signature: no Python check of the values
            args = (J1, e1, q, limits, lam, dt, de1_dt, secondary, qdot_prev)
            done = kc.fast_call(self, args)
            if done is not None:
                return _new_result(LawResult, (done[0], lazy_diagnostics(kc.diagnose, *done[1])))
        x = validate_inputs(
            J1=J1,
            e1=e1,
            q=q,
            limits=limits,
            lam=lam,
            dt=dt,
            de1_dt=de1_dt,
            secondary=secondary,
            qdot_prev=qdot_prev,
        )
        if kernel:
            done = kc.kernel_call(self, x)
            if done is not None:
                return LawResult(done[0], lazy_diagnostics(kc.diagnose, *done[1]))
        result = self.compute(x)
        task = self.task_command(x) if self.scaling == "secondary-first" else None
        safe = apply_safety(
            result.qdot, x.q, x.limits, x.dt, qdot_prev=x.qdot_prev, shield=self.shield, task=task
        )
        if not safe.events:  # the diagnostics are unchanged
            return result if safe.qdot is result.qdot else LawResult(safe.qdot, result.diagnostics)
        d = result.diagnostics
        events = (*d.events, *safe.events)
        merged = Diagnostics(*_BEFORE_EVENTS(d), events, d.info)  # type: ignore[call-arg]
        return LawResult(safe.qdot, merged)

    @property
    def filter_threshold(self) -> float:
        """Relative filter threshold of the robust task inverse (0 when ``robust`` is off)."""
        return ROBUST_FILTER if self.robust else 0.0

    def svd(self, J1: FloatArray) -> TaskSVD:
        """The task SVD with this law's cut-off and, if ``robust``, the filtered inverse."""
        return task_svd(J1, self.rcond, self.filter_threshold)

    def task_command(self, x: LawInputs) -> FloatArray:
        """The primary-task part of the command, ``-λ J1⁺ e_eff`` (for secondary-first scaling)."""
        return np.asarray(-x.lam * (self.svd(x.J1).pinv @ x.e_eff))

    @abc.abstractmethod
    def compute(self, x: LawInputs) -> LawResult:
        """Compute the raw command from validated inputs (implemented by each law)."""

    def reset(self) -> None:  # noqa: B027 - optional hook, stateless laws need nothing
        """Forget any state kept between calls (no-op for stateless laws)."""

    def __repr__(self) -> str:
        names = [o.name for o in type(self).OPTIONS]
        names += sorted(k for k in vars(self) if k not in names and not k.startswith("_"))
        opts = ", ".join(f"{k}={getattr(self, k)!r}" for k in names)
        return f"make_law({self.name!r}{', ' if opts else ''}{opts})"


_BEFORE_EVENTS = operator.attrgetter(*[f.name for f in fields(Diagnostics)][:-2])
"""The fields of :class:`Diagnostics` before ``events`` and ``info`` (its last two), in order."""
if [f.name for f in fields(Diagnostics)][-2:] != ["events", "info"]:  # pragma: no cover
    raise RuntimeError("Diagnostics must end with its events and info fields")


# -- diagnostics built when read ------------------------------------------------------------------

_FIELD_NAMES = tuple(f.name for f in fields(Diagnostics))
_ALL_FIELDS = operator.attrgetter(*_FIELD_NAMES)
"""Every field of a :class:`Diagnostics`, in order."""


class LazyDiagnostics(Diagnostics):
    """A :class:`Diagnostics` whose fields are computed on the first read of any of them.

    A law call through the step kernel (:mod:`redservo.redundancy.kernel_call`) and the
    compiled :class:`~redservo.control.Controller` step end with the kernel's raw outputs
    (integer and float codes, event masks); turning them into a frozen :class:`Diagnostics`
    with worded events costs more than the law itself on a small arm, and a loop that only
    sends ``qdot`` never reads it. The build works on a copy of what the call produced (the
    kernel's buffer, the law's options as they were, ``q`` and ``q̇`` when the safety layer
    raised events), so a later change of the law, of ``q`` or of ``qdot`` in place does not
    change what it says. It compares equal to the eager diagnostics, and prints, copies and
    pickles as a plain :class:`Diagnostics`.
    """

    __slots__ = ("_build",)

    def __getattr__(self, name: str) -> Any:
        """Called only for a field not yet set: build them all, then read ``name``."""
        try:
            build = object.__getattribute__(self, "_build")
        except AttributeError:  # made by ``dataclasses.replace``: every field is set
            raise AttributeError(name) from None
        if build is None or name not in _FIELD_NAMES:
            raise AttributeError(name)
        fn, args = build
        try:
            eager = fn(*args)
        except AttributeError as err:  # not a missing field: say what failed
            raise RuntimeError(f"building the diagnostics failed: {err}") from err
        for key, value in zip(_FIELD_NAMES, _ALL_FIELDS(eager), strict=True):
            object.__setattr__(self, key, value)
        object.__setattr__(self, "_build", None)
        return object.__getattribute__(self, name)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Diagnostics):
            return bool(_ALL_FIELDS(self) == _ALL_FIELDS(other))
        return NotImplemented

    __hash__ = Diagnostics.__hash__

    def __repr__(self) -> str:
        return repr(self.eager())

    def __reduce__(self) -> tuple[Any, ...]:
        return (Diagnostics, _ALL_FIELDS(self))

    def eager(self) -> Diagnostics:
        """The same diagnostics as a plain :class:`~redservo.Diagnostics`."""
        return Diagnostics(*_ALL_FIELDS(self))


def lazy_diagnostics(fn: Callable[..., Diagnostics], *args: Any) -> LazyDiagnostics:
    """Diagnostics that are ``fn(*args)``, computed when first read (``args`` must not
    change in the meantime: pass copies of anything the caller may modify)."""
    d = object.__new__(LazyDiagnostics)
    object.__setattr__(d, "_build", (fn, args))
    return d


_SET_BUILD = LazyDiagnostics._build.__set__  # type: ignore[attr-defined]
"""Sets a :class:`LazyDiagnostics`' slot ``_build`` (the frozen dataclass's ``__setattr__``
refuses it)."""


_NEW_LAZY = object.__new__


# -- registry ------------------------------------------------------------------------------------

_REGISTRY: dict[str, type[Law]] = {}
_KERNEL_STEP: dict[type[Law], bool] = {}
"""Per law class, whether its call runs through the step kernel (:attr:`Law._kernel_step`)."""
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
        **options: The law's keyword-only options (see its class docstring), and the
            safety options ``shield``, ``robust``, ``scaling`` every law has (:class:`Law`).

    Raises:
        UnknownNameError: ``name`` is not a known method.
        ConfigurationError: an option is unknown or has an invalid value.
    """
    cls = law_class(name)
    params = inspect.signature(cls.__init__).parameters
    allowed = [
        p for p in params if p != "self" and params[p].kind is inspect.Parameter.KEYWORD_ONLY
    ]
    safety = {k: options.pop(k) for k in SAFETY_OPTIONS if k in options}
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ConfigurationError(
            f"method {name!r} has no option(s) {unknown}; its options are: "
            f"{', '.join([*allowed, *SAFETY_OPTIONS])}",
            argument=unknown[0],
        )
    return cls(**options).set_safety(**safety)
