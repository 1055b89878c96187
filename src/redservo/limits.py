"""Joint limits, activation thresholds and the joint-limit cost of Chaumette & Marchand 2001.

All positions are in joint units: metres for prismatic axes, radians for
revolute ones. Equation numbers refer to Chaumette & Marchand 2001 (CM01) unless
stated; MC05 eqs. 28-29 define the same cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, _to_float, as_vector
from redservo.errors import ConfigurationError, JointLimitError, ShapeError

__all__ = ["JointLimits"]


def _rate_limit(
    value: ArrayLike | None, name: str, n: int, unit: str, *, allow_zero: bool = False
) -> FloatArray | None:
    """Return a per-joint positive limit as an (n,) array (a scalar is broadcast), or None
    (``allow_zero``: zeros are accepted too)."""
    if value is None:
        return None
    try:
        arr = _to_float(value, name)  # numbers only: "2.0" is refused, not parsed
    except ShapeError:
        raise ConfigurationError(
            f"{name} must be None, a number > 0 ({unit}) or one per joint, got {value!r}",
            argument=name,
        ) from None
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ConfigurationError(
            f"{name} must be a scalar or have {n} entries (one per joint), got shape {arr.shape}",
            argument=name,
        )
    bad = np.flatnonzero(~(np.isfinite(arr) & ((arr >= 0.0) if allow_zero else (arr > 0.0))))
    if bad.size:
        i = int(bad[0])
        raise ConfigurationError(
            f"{name}[{i}] = {float(arr[i])!r} must be a finite number {'>=' if allow_zero else '>'} 0 "
            f"({unit})",
            argument=name,
        )
    arr = arr.copy()
    arr.setflags(write=False)
    return arr


def _band(value: object, name: str, upper: float, meaning: str) -> float:
    """Return ``value`` as a float in the allowed interval, or raise naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise ConfigurationError(f"{name} must be a number {meaning}, got {value!r}", argument=name)
    v = float(value)
    if not (math.isfinite(v) and 0.0 <= v < upper):
        raise ConfigurationError(f"{name} must be a number {meaning}, got {value!r}", argument=name)
    return v


def _checked_bounds(
    q_min: ArrayLike, q_max: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(q_min, q_max, range)`` as float vectors (rad or m), checked: at least one joint,
    ``q_max > q_min`` everywhere, every bound within ±1e15 with a finite range.

    Raises:
        ShapeError: not vectors of one length.
        JointLimitError: a joint's bounds are not usable (naming the joint and its bounds).
    """
    with np.errstate(over="ignore"):  # ±1e308 limits are reported below, not warned about
        lo = as_vector(q_min, "q_min")
        hi = as_vector(q_max, "q_max", lo.shape[0])
    if lo.shape[0] == 0:
        raise JointLimitError("q_min and q_max must have at least one joint", argument="q_min")
    bad = np.flatnonzero(~(hi > lo))
    if bad.size:
        i = int(bad[0])
        raise JointLimitError(
            f"q_max must be strictly greater than q_min for every joint; joint {i} has "
            f"q_min={lo[i]:.17g}, q_max={hi[i]:.17g}",
            argument="q_max",
            joint=i,
            lower=float(lo[i]),
            upper=float(hi[i]),
        )
    with np.errstate(over="ignore"):
        rng = hi - lo
    huge = np.flatnonzero(~np.isfinite(rng) | (np.abs(lo) > 1e15) | (np.abs(hi) > 1e15))
    if huge.size:
        i = int(huge[0])
        raise JointLimitError(
            f"joint {i}: limits [{lo[i]:.6g}, {hi[i]:.6g}] are not usable joint limits "
            "(each must be within ±1e15 m or rad, with a finite range); give the robot's "
            "real limits",
            argument="q_min",
            joint=i,
            lower=float(lo[i]),
            upper=float(hi[i]),
        )
    return lo, hi, rng


def _keep_out(
    margin: float, margin_abs: ArrayLike | None, rho: float, rng: FloatArray
) -> FloatArray:
    """The keep-out margin per joint (m or rad): ``margin_abs`` as given, else ``margin``
    (a fraction of each range); either must stay inside the activation band ``rho·range``.

    Raises:
        ConfigurationError: a margin outside ``[0, rho·range)`` (naming the argument).
    """
    if margin_abs is not None:
        mabs = _rate_limit(margin_abs, "margin_abs", rng.shape[0], "m or rad", allow_zero=True)
        assert mabs is not None
        over = np.flatnonzero(mabs >= rho * rng)
        if over.size:
            i = int(over[0])
            raise ConfigurationError(
                f"margin_abs[{i}] = {mabs[i]:.6g} must be below the band rho·range = "
                f"{rho * rng[i]:.6g}",
                argument="margin_abs",
            )
        return mabs
    frac = _band(margin, "margin", rho, f"in [0, rho = {rho:g}), a fraction of the range")
    return frac * rng


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Real joint limits ``q̄``, activation thresholds ``q̃`` (CM01 eq. 3) and rate limits.

    ``q̃_min = q̄_min + rho Δq̄`` and ``q̃_max = q̄_max - rho Δq̄`` with
    ``Δq̄_i = q̄_max,i - q̄_min,i`` per axis (CM01 prints Δq̄ without the index;
    docs/formulas.md §5). In normalized coordinates ``2 (q - centre)/Δq̄`` the
    thresholds sit at ``±(1 - 2 rho)``: ``rho = 0.1`` puts them at **±0.8**.

    The optional rate limits and the safety margin are what a real arm needs
    (docs/safety.md): every control law honours ``qdot_max`` and ``qddot_max``,
    and the shield keeps ``q + dt q̇`` within ``[q̄_min + margin, q̄_max - margin]``.

    Args:
        q_min: (n,) lower limits ``q̄_min`` (m or rad).
        q_max: (n,) upper limits ``q̄_max`` (m or rad), each strictly above ``q_min``.
        rho: Width of the critical band as a fraction of the range, in (0, 1/2).
        qdot_max: Joint velocity limits (rad/s or m/s), a scalar or (n,), or None.
        qddot_max: Joint acceleration limits (rad/s² or m/s²), a scalar or (n,), or None.
        margin: Keep-out distance at each hard limit, as a fraction of the range in
            [0, rho) (default 0: the hard limit itself). ``margin_abs`` gives it in joint units.
        margin_abs: Keep-out distance in joint units (m or rad), scalar or (n,); overrides
            ``margin`` when given.

    Raises:
        JointLimitError: limits not ordered, not finite, or a range that overflows float64.
        ConfigurationError: ``rho``, a rate limit or the margin has an invalid value.
    """

    q_min: FloatArray
    q_max: FloatArray
    rho: float = 0.1
    qdot_max: FloatArray | None = None
    qddot_max: FloatArray | None = None
    margin_abs: FloatArray = field(init=False, repr=False)
    range: FloatArray = field(init=False, repr=False)
    q_tilde_min: FloatArray = field(init=False, repr=False)
    q_tilde_max: FloatArray = field(init=False, repr=False)
    _center: FloatArray = field(init=False, repr=False)

    def __init__(
        self,
        q_min: ArrayLike,
        q_max: ArrayLike,
        rho: float = 0.1,
        *,
        qdot_max: ArrayLike | None = None,
        qddot_max: ArrayLike | None = None,
        margin: float = 0.0,
        margin_abs: ArrayLike | None = None,
    ) -> None:
        lo, hi, rng = _checked_bounds(q_min, q_max)
        rho_f = _band(rho, "rho", 0.5, "in (0, 0.5), the band width as a fraction of the range")
        if rho_f <= 0.0:
            raise ConfigurationError(f"rho must lie in (0, 0.5), got {rho!r}", argument="rho")
        n = lo.shape[0]
        mabs = _keep_out(margin, margin_abs, rho_f, rng)
        for name, value in (
            ("q_min", lo),
            ("q_max", hi),
            ("range", rng),
            ("q_tilde_min", lo + rho_f * rng),
            ("q_tilde_max", hi - rho_f * rng),
            ("_center", 0.5 * (lo + hi)),
            ("margin_abs", np.array(mabs, dtype=float)),
        ):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "rho", rho_f)
        object.__setattr__(self, "qdot_max", _rate_limit(qdot_max, "qdot_max", n, "rad/s or m/s"))
        object.__setattr__(
            self, "qddot_max", _rate_limit(qddot_max, "qddot_max", n, "rad/s² or m/s²")
        )

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q_min.shape[0])

    @property
    def center(self) -> FloatArray:
        """(n,) mid-range configuration ``(q̄_min + q̄_max)/2``."""
        return 0.5 * (self.q_min + self.q_max)

    @property
    def margin_fraction(self) -> FloatArray:
        """(n,) the keep-out margin as a fraction of each range."""
        return self.margin_abs / self.range

    @property
    def safe_min(self) -> FloatArray:
        """(n,) ``q̄_min + margin``: the lowest position the shield lets a command reach."""
        return self.q_min + self.margin_abs

    @property
    def safe_max(self) -> FloatArray:
        """(n,) ``q̄_max - margin``: the highest position the shield lets a command reach."""
        return self.q_max - self.margin_abs

    def replace(self, **changes: object) -> JointLimits:
        """Return a copy with some of ``rho``, ``qdot_max``, ``qddot_max``, ``margin``,
        ``margin_abs`` changed (``margin`` replaces ``margin_abs``)."""
        kw: dict[str, object] = {
            "rho": self.rho,
            "qdot_max": self.qdot_max,
            "qddot_max": self.qddot_max,
            "margin_abs": self.margin_abs,
        }
        if "margin" in changes:
            kw.pop("margin_abs")
        unknown = set(changes) - {*kw, "margin", "margin_abs"}
        if unknown:
            raise ConfigurationError(f"JointLimits.replace: unknown field(s) {sorted(unknown)}")
        kw.update(changes)
        return JointLimits(self.q_min, self.q_max, **kw)  # type: ignore[arg-type]

    def with_rho(self, rho: float) -> JointLimits:
        """Return a copy with another band width ``rho`` (rate limits and margin kept)."""
        return self.replace(rho=rho)

    def without_rates(self) -> JointLimits:
        """Return a copy with position limits only (no velocity/acceleration limits, no margin):
        the setting of the papers' experiments."""
        return JointLimits(self.q_min, self.q_max, self.rho)

    # -- validation ---------------------------------------------------------------------------

    def check(self, q: ArrayLike, name: str = "q", *, tol: float = 1e-9) -> FloatArray:
        """Return ``q`` as an array, raising if its shape is wrong or it lies outside the limits.

        Args:
            q: (n,) joint configuration.
            name: Argument name for the message.
            tol: Allowed excess beyond a limit, in joint units.

        Raises:
            ShapeError: ``q`` is not a finite (n,) vector.
            JointLimitError: some ``q_i`` is outside ``[q̄_min,i - tol, q̄_max,i + tol]``.
        """
        qa = as_vector(q, name, self.n)
        # The excess itself is compared with tol (as the laws' validation does): q_min - tol
        # would round to q_min, or one float step below it, for |q| ~ 1e7 and beyond.
        with np.errstate(over="ignore"):
            out = np.flatnonzero((qa - self.q_min < -tol) | (self.q_max - qa < -tol))
        if out.size:
            i = int(out[0])
            lo, hi, v = float(self.q_min[i]), float(self.q_max[i]), float(qa[i])
            by = lo - v if v < lo else v - hi
            raise JointLimitError(
                f"{name}[{i}] = {v!r} is outside the joint limits [{lo!r}, {hi!r}] by {by!r} "
                f"(tolerance {tol:g}); {out.size} joint(s) out of range: {out.tolist()}",
                argument=name,
                joint=i,
                value=v,
                lower=lo,
                upper=hi,
            )
        return qa

    def contains(self, q: ArrayLike) -> bool:
        """True when every joint of ``q`` lies within ``[q̄_min, q̄_max]``."""
        qa = np.asarray(q, dtype=float)
        return bool(np.all((qa >= self.q_min) & (qa <= self.q_max)))

    # -- geometry -----------------------------------------------------------------------------

    def normalized(self, q: ArrayLike) -> FloatArray:
        """Return ``2 (q - center) / range``: -1 at ``q̄_min``, +1 at ``q̄_max``, ±(1-2 rho) at ``q̃``."""
        return 2.0 * (np.asarray(q, dtype=float) - self.center) / self.range

    def distance(self, q: ArrayLike) -> FloatArray:
        """Return (n,) the distance to the nearest real limit, ``min(q - q̄_min, q̄_max - q)``."""
        qa = np.asarray(q, dtype=float)
        return np.minimum(qa - self.q_min, self.q_max - qa)

    def margin(self, q: ArrayLike) -> FloatArray:
        """Return (n,) the distance to the nearest limit as a fraction of the range (0 at a limit, 0.5 at mid-range)."""
        return self.distance(q) / self.range

    def in_band(self, q: ArrayLike) -> FloatArray:
        """Return (n,) booleans: axis between its threshold ``q̃`` and its real limit (or beyond)."""
        qa = np.asarray(q, dtype=float)
        return np.asarray((qa <= self.q_tilde_min) | (qa >= self.q_tilde_max))

    # -- cost (CM01 eqs. 4-6, MC05 eqs. 28-29) --------------------------------------------------

    def excess(self, q: ArrayLike) -> FloatArray:
        """Return (n,) ``s_i`` of CM01 eq. 5: signed excess beyond the threshold, 0 inside."""
        qa = np.asarray(q, dtype=float)
        return np.where(
            qa > self.q_tilde_max,
            qa - self.q_tilde_max,
            np.where(qa < self.q_tilde_min, qa - self.q_tilde_min, 0.0),
        )

    def cost(self, q: ArrayLike) -> float:
        """Return the joint-limit cost ``h_s = 1/2 Σ s_i² / Δq̄_i`` (CM01 eq. 4), in joint units."""
        s = self.excess(q)
        return float(0.5 * np.sum(s * s / self.range))

    def gradient(self, q: ArrayLike) -> FloatArray:
        """Return ``e2 = (∂h_s/∂q)^T`` (n,), ``e2_i = s_i / Δq̄_i`` (CM01 eq. 6); dimensionless."""
        return self.excess(q) / self.range

    # -- the iterative scheme's helpers (CM01 eqs. 8 and 17) ------------------------------------

    def gamma(self, q_hat: ArrayLike) -> FloatArray:
        """Return (n,) the smoothing gains ``γ_k`` of CM01 eq. 17 (corrected), in [0, 1].

        ``γ = 0`` between the thresholds, rising linearly to 1 at the real limit
        (docs/formulas.md §7.5 fixes the printed third case), clamped to 1
        beyond it. ``γ = 1`` everywhere is the basic scheme.

        Args:
            q_hat: (n,) predicted configuration ``q̂(t+1)`` (CM01 eq. 8).
        """
        qh = np.asarray(q_hat, dtype=float)
        g = np.maximum(self.q_tilde_min - qh, qh - self.q_tilde_max)
        g /= self.rho * self.range
        np.minimum(g, 1.0, out=g)
        return np.maximum(g, 0.0, out=g)

    def critical(self, q: ArrayLike, q_hat: ArrayLike) -> FloatArray:
        """Return (n,) booleans: the axes that are *critical* (docs/formulas.md §7.2).

        Axis k is critical when its predicted position ``q̂_k`` lies in the band
        ``[q̄_min, q̃_min] ∪ [q̃_max, q̄_max]`` (or beyond the real limit) and it moves
        toward the nearest real limit, ``dist(q̂_k) < dist(q_k)``.

        Args:
            q: (n,) current configuration.
            q_hat: (n,) predicted configuration.
        """
        qa = np.asarray(q, dtype=float)
        qh = np.asarray(q_hat, dtype=float)
        # In the band: max(q̂ - q̃_max, q̃_min - q̂) >= 0 (only one can be, as q̃_min < q̃_max).
        # Toward the nearest limit: (q̂ - q) has the sign of (q̂ - centre) (upper or lower band).
        in_band = np.maximum(qh - self.q_tilde_max, self.q_tilde_min - qh) >= 0.0
        toward = (qh - qa) * (qh - self._center) > 0.0
        return np.asarray(in_band & toward)
