"""A visual task in joint space: ``e1 = C (s - s*)`` and ``J1 = C L_s J(q)`` (CM01 eqs. 23-25).

A task stacks features, each bound to a named scene object, and keeps the
desired values ``s*``. It is a pure function of the *measured* camera pose and
of the robot Jacobian the controller believes in, so that modelling errors
(depth, hand-eye calibration) are injected by the caller:

    state = task.evaluate(scene, bMc, J, t)
    law(J1=state.J1, e1=state.e1, ...)

**Depth used in L** (docs/formulas.md §4.3; CM01 uses the current depth):
``depth="current"`` (default) evaluates ``L_s`` at the current value and
current inverse-depth parameters; ``"desired"`` uses the inverse-depth
parameters of the desired pose; ``"mean"`` their average. In every case ``L_s``
is evaluated at the *current* feature value ``s``.

**Combination matrix** (CM01 eq. 25): when the stacked ``L`` (k x 6) at the
desired pose has rank r < k, ``C = U_r^T`` (r x k), the first r left singular
vectors of ``L*``. This is ``C = W H^+|_{s*}`` for the particular choice
``W = Σ_r V_r^T`` of eq. 25 (with ``J(q)`` onto, ``Ker H = Ker L J``); then
``J1 = C L J`` has full row rank r. Otherwise ``C = I``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_matrix, as_transform, as_vector
from redservo.errors import ConfigurationError, ShapeError
from redservo.features import compiled_points as _CP
from redservo.features import plan as plan
from redservo.features.base import Feature
from redservo.kernels import lazy
from redservo.scene import Scene

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import features as _K
else:
    _K = lazy("features")
_SCENE_CMO = Scene.cMo
__all__ = ["DepthMode", "TaskState", "TaskTerm", "VisualTask", "task_rows"]

DepthMode = Literal["current", "desired", "mean"]
_DEPTH_MODES = ("current", "desired", "mean")


class _PoseSource(Protocol):
    """Anything that can give an object's pose in the camera frame (a :class:`~redservo.scene.Scene`)."""

    def cMo(self, name: str, bMc: FloatArray, t: float) -> FloatArray: ...


@dataclass(frozen=True)
class TaskTerm:
    """One feature of the task, bound to the scene object it observes.

    Attributes:
        feature: The visual feature (holds the object's geometry in the object frame).
        target: Name of the scene object.
    """

    feature: Feature
    target: str


class TaskState(NamedTuple):
    """Everything the task computed at one instant.

    All arrays are fresh; ``k`` is the number of stacked feature components,
    ``m`` the task dimension (rows of ``C``), ``n`` the number of joints.
    """

    s: FloatArray
    """(k,) current feature values (noise included, if any)."""
    e: FloatArray
    """(k,) feature error ``s - s*``, angles wrapped to (-π, π]."""
    e1: FloatArray
    """(m,) task error ``C (s - s*)``."""
    L: FloatArray
    """(k, 6) stacked interaction matrix used by the controller."""
    J1: FloatArray
    """(m, n) task Jacobian ``C L J(q)``."""
    inv_depth: tuple[FloatArray, ...]
    """True inverse-depth parameters per term."""


_new_state: Callable[[type[TaskState], tuple[object, ...]], TaskState] = tuple.__new__
"""``TaskState`` from its six fields without the Python-level ``__new__`` (the hot path)."""


def task_rows(
    e: FloatArray, L: FloatArray, C: FloatArray | None, J: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """CM01 eq. 25 on the object path: ``(e1, J1) = (C e, C L J)``, or ``(e, L J)`` without a
    combination matrix (``C`` None); ``e`` (k,), ``L`` (k, 6), ``J`` (6, n), ``C`` (m, k).

    numpy's ``@`` in this order (``(C L) J``), as BLAS does it in the step kernel
    (:func:`redservo.kernels.control.task_rows`), so that both agree to the last bit.
    """
    if C is None:
        return e, L @ J
    return C @ e, (C @ L) @ J


class VisualTask:
    """A stack of visual features with desired values.

    Args:
        terms: The features and the objects they observe.
        s_star: (k,) desired feature values, stacked in term order.
        inv_depth_star: Inverse-depth parameters per term at the desired pose
            (needed for ``depth="desired"`` or ``"mean"`` and for ``C``); use
            :meth:`from_desired_poses` to get them.
        depth: Which depth enters ``L``: ``"current"``, ``"desired"`` or ``"mean"``.
        C: (m, k) combination matrix; computed from ``L*`` when omitted.
    """

    def __init__(
        self,
        terms: Sequence[TaskTerm],
        s_star: ArrayLike,
        *,
        inv_depth_star: Sequence[ArrayLike] | None = None,
        depth: DepthMode = "current",
        C: ArrayLike | None = None,
    ) -> None:
        if not terms:
            raise ConfigurationError("a task needs at least one feature term")
        self.terms: tuple[TaskTerm, ...] = tuple(terms)
        self.sizes = tuple(t.feature.size for t in self.terms)
        k = sum(self.sizes)
        self.s_star = as_vector(s_star, "s_star", k)
        if depth not in _DEPTH_MODES:
            raise ConfigurationError(f"depth must be one of {_DEPTH_MODES}, got {depth!r}")
        if depth != "current" and inv_depth_star is None:
            raise ConfigurationError(
                f"depth={depth!r} needs the desired pose; build the task with "
                "VisualTask.from_desired_poses(...) or pass inv_depth_star"
            )
        self.depth: DepthMode = depth
        self.inv_depth_star: tuple[FloatArray, ...] | None = None
        if inv_depth_star is not None:
            if len(inv_depth_star) != len(self.terms):
                raise ShapeError(
                    f"inv_depth_star needs one entry per term ({len(self.terms)}), "
                    f"got {len(inv_depth_star)}"
                )
            self.inv_depth_star = tuple(
                as_vector(d, f"inv_depth_star[{i}]") for i, d in enumerate(inv_depth_star)
            )
        # Terms whose error is not a plain difference (angles): each wraps its own error,
        # e.g. the moment α has period π, a line's θ period 2π.
        offsets = np.cumsum((0, *self.sizes))
        self._wrapped = tuple(
            (term, int(offsets[i]), int(offsets[i + 1]))
            for i, term in enumerate(self.terms)
            if any(term.feature.angular)
        )
        # How evaluate() runs, fixed once: the points of one target in one kernel call.
        self._plan = plan.make_plan(
            [t.feature for t in self.terms],
            [t.target for t in self.terms],
            self.sizes,
            self.inv_depth_star,
        )
        # A subclass redefining measure/error/interaction takes the plain path through them.
        own = ("measure", "error", "interaction")
        self._custom = any(getattr(type(self), m) is not getattr(VisualTask, m) for m in own)
        self._group = None if self._custom else plan.single_group(self._plan)
        self.C: FloatArray | None
        if C is not None:
            self.C = as_matrix(C, "C", cols=k)
        elif self.inv_depth_star is not None:
            self.C = self._combination_matrix(self.desired_interaction())
        else:
            self.C = None

    # -- construction --------------------------------------------------------------------------

    @classmethod
    def from_desired_poses(
        cls,
        terms: Sequence[TaskTerm],
        desired: Mapping[str, ArrayLike],
        *,
        depth: DepthMode = "current",
        C: ArrayLike | None = None,
    ) -> VisualTask:
        """Build a task whose ``s*`` is what the camera sees at a desired pose.

        Args:
            terms: The features and the objects they observe.
            desired: For each target name, ``c*Mo`` (4x4): the object's pose in the
                desired camera frame.
            depth: See the class docstring.
            C: Optional combination matrix.

        Raises:
            GeometryError: a feature is not valid at the desired pose.
            UnknownNameError: a term's target has no desired pose.
        """
        from redservo.errors import UnknownNameError

        s_parts, d_parts = [], []
        for term in terms:
            if term.target not in desired:
                raise UnknownNameError(
                    f"no desired pose for target {term.target!r}; given: {sorted(desired)}"
                )
            meas = term.feature.measure(np.asarray(desired[term.target], dtype=float))
            s_parts.append(meas.s)
            d_parts.append(meas.inv_depth)
        return cls(terms, np.concatenate(s_parts), inv_depth_star=d_parts, depth=depth, C=C)

    @staticmethod
    def _combination_matrix(L_star: FloatArray) -> FloatArray | None:
        U, sigma, _ = np.linalg.svd(L_star)
        tol = max(L_star.shape) * np.finfo(float).eps * (sigma[0] if sigma.size else 0.0)
        r = int(np.count_nonzero(sigma > max(tol, 1e-9 * (sigma[0] if sigma.size else 0.0))))
        if r >= L_star.shape[0]:
            return None
        return np.asarray(U[:, :r].T.copy())

    # -- evaluation ----------------------------------------------------------------------------

    @property
    def k(self) -> int:
        """Number of stacked feature components."""
        return int(self.s_star.shape[0])

    @property
    def m(self) -> int:
        """Task dimension (rows of ``e1``)."""
        return self.k if self.C is None else int(self.C.shape[0])

    @property
    def names(self) -> tuple[str, ...]:
        """Component names, ``target.feature_component``."""
        return tuple(f"{t.target}.{n}" for t in self.terms for n in t.feature.names)

    def desired_interaction(self) -> FloatArray:
        """Return the stacked ``L*`` (k, 6) at ``s*`` with the desired depth."""
        if self.inv_depth_star is None:
            raise ConfigurationError("the desired depth is unknown; use from_desired_poses")
        parts, i = [], 0
        for term, size, d in zip(self.terms, self.sizes, self.inv_depth_star, strict=True):
            parts.append(term.feature.interaction(self.s_star[i : i + size], d))
            i += size
        return np.vstack(parts)

    def error(self, s: FloatArray) -> FloatArray:
        """Return ``s - s*`` (k,), each angle wrapped by its feature's ``error`` (to (-π, π] or
        (-π/2, π/2] for an orientation of period π)."""
        e = s - self.s_star
        for term, a, b in self._wrapped:
            e[a:b] = term.feature.error(s[a:b], self.s_star[a:b])
        return e

    def measure(
        self, scene: _PoseSource, bMc: FloatArray, t: float
    ) -> tuple[FloatArray, tuple[FloatArray, ...]]:
        """Return the stacked value ``s`` (k,) and the true inverse-depth parameters per term.

        Raises:
            GeometryError: a feature is invalid at this pose (e.g. its object is behind the camera).
        """
        s, inv_depth, _ = plan.measure(self._plan, self._poses(scene, bMc, t))
        return s, inv_depth

    def _poses(self, scene: _PoseSource, bMc: FloatArray, t: float) -> list[FloatArray]:
        """``cMo`` (4x4) of each target: a :class:`~redservo.scene.Scene`'s own are built from
        validated transforms; those of another pose source are checked."""
        if type(scene).cMo is _SCENE_CMO:
            return [scene.cMo(name, bMc, t) for name in self._plan.targets]
        return [
            np.ascontiguousarray(as_transform(scene.cMo(name, bMc, t), "cMo"))
            for name in self._plan.targets
        ]

    def evaluate(
        self,
        scene: _PoseSource,
        bMc: FloatArray,
        J: FloatArray,
        t: float = 0.0,
        *,
        depth_scale: float = 1.0,
        noise: FloatArray | None = None,
    ) -> TaskState:
        """Measure the features at camera pose ``bMc`` and build ``e1`` and ``J1``.

        Args:
            scene: Gives the objects' poses (``scene.cMo(name, bMc, t)``).
            bMc: 4x4 true camera pose in the robot base frame.
            J: (6, n) robot Jacobian the controller uses (``cVe eJe``, possibly
                with a wrong ``eMc`` to model a calibration error).
            t: Time (s), for moving objects.
            depth_scale: The controller's depth estimate is ``Ẑ = depth_scale · Z``
                (1 = exact); the inverse-depth parameters are divided by it.
            noise: (k,) additive measurement noise on ``s``, in feature units.

        Raises:
            GeometryError: a feature is invalid at this pose.
            ShapeError: ``bMc``, ``J`` or ``noise`` has the wrong shape or is not finite.
            ConfigurationError: ``t`` is not finite, ``depth_scale`` not positive and finite.
        """
        group = self._group
        if group is not None and noise is None and type(scene).cMo is _SCENE_CMO:
            # The hot path: the points of one target (docs/speed.md, "Public object path"),
            # in one compiled call when the kernels are compiled and the inputs fit it.
            if depth_scale == 1.0 and self.depth == "current":
                done = _CP.evaluate(scene, self, group, bMc, J, t)  # type: ignore[arg-type]
                if done is not None:
                    return _new_state(TaskState, done)
            cMo = scene.cMo(group.target_name, bMc, t)
            s, iz, bad = _K.points_measure(cMo, group.points)
            if bad >= 0:
                plan.raise_behind(group, bad, cMo)
            if depth_scale != 1.0 or self.depth != "current":
                return self._points_state(s, iz, group.split(iz), J, depth_scale)
            if type(J) is not np.ndarray or J.ndim != 2 or J.shape[0] != 6:
                J = as_matrix(J, "J", 6)
            L = _K.points_interaction(s, iz)
            e = s - self.s_star
            e1, J1 = task_rows(e, L, self.C, J)
            return _new_state(TaskState, (s, e, e1, L, J1, group.split(iz)))
        parts: Sequence[FloatArray] = ()
        if self._custom:
            s, inv_depth = self.measure(scene, bMc, t)
        else:
            s, inv_depth, parts = plan.measure(self._plan, self._poses(scene, bMc, t))
        if noise is not None:
            s = s + as_vector(noise, "noise", self.k)
        if group is not None:
            return self._points_state(s, parts[0], inv_depth, J, depth_scale)
        return self._state(s, inv_depth, parts, J, depth_scale)

    def evaluate_measured(
        self,
        s: FloatArray,
        inv_depth: Sequence[FloatArray],
        J: FloatArray,
        *,
        depth_scale: float = 1.0,
    ) -> TaskState:
        """Build ``e1`` and ``J1`` from *measured* features (the sensor hook's entry point).

        Args:
            s: (k,) measured feature values (normalized image units).
            inv_depth: Inverse-depth parameters per term, as the sensor estimated them.
            J: (6, n) robot Jacobian the controller uses.
            depth_scale: Extra depth-estimate factor ``Ẑ = depth_scale · Z``.

        Raises:
            ShapeError: ``s``, ``inv_depth`` or ``J`` has the wrong shape or is not finite.
            ConfigurationError: ``depth_scale`` is not positive and finite.
        """
        sv = as_vector(s, "s", self.k)
        parts: Sequence[FloatArray] = () if self._custom else plan.parts_of(self._plan, inv_depth)
        if self._group is not None:
            return self._points_state(sv, parts[0], tuple(inv_depth), J, depth_scale)
        return self._state(sv, tuple(inv_depth), parts, J, depth_scale)

    def _points_state(
        self,
        s: FloatArray,
        iz: FloatArray,
        inv_depth: tuple[FloatArray, ...],
        J: FloatArray,
        depth_scale: float,
    ) -> TaskState:
        """:meth:`_state` of a task of points of one target (``iz`` their inverse depths)."""
        if not (type(J) is np.ndarray and J.ndim == 2 and J.shape[0] == 6):
            J = as_matrix(J, "J", 6)
        if self.depth != "current" or depth_scale != 1.0:
            iz = plan.depth_option(iz, self._group.star, self.depth, depth_scale)  # type: ignore[union-attr]
        L = _K.points_interaction(s, iz)
        e = s - self.s_star
        e1, J1 = task_rows(e, L, self.C, J)
        return _new_state(TaskState, (s, e, e1, L, J1, inv_depth))

    def _state(
        self,
        s: FloatArray,
        inv_depth: tuple[FloatArray, ...],
        parts: Sequence[FloatArray],
        J: FloatArray,
        depth_scale: float,
    ) -> TaskState:
        """The task's state at the value ``s`` with the inverse depths ``parts`` per segment."""
        if not (type(J) is np.ndarray and J.ndim == 2 and J.shape[0] == 6):
            J = as_matrix(J, "J", 6)
        L = (
            self.interaction(s, inv_depth, depth_scale=depth_scale)
            if self._custom
            else plan.interaction(self._plan, s, parts, self.depth, depth_scale)
        )
        e = self.error(s)
        e1, J1 = task_rows(e, L, self.C, J)
        return TaskState(s, e, e1, L, J1, inv_depth)

    def interaction(
        self, s: FloatArray, inv_depth: Sequence[FloatArray], *, depth_scale: float = 1.0
    ) -> FloatArray:
        """Return the stacked ``L`` (k, 6) at value ``s`` with the task's depth option.

        Raises:
            ShapeError: ``s`` or ``inv_depth`` has the wrong shape or is not finite.
            ConfigurationError: ``depth_scale`` is not positive and finite.
        """
        sv = as_vector(s, "s", self.k)
        parts = plan.parts_of(self._plan, inv_depth)
        return plan.interaction(self._plan, sv, parts, self.depth, depth_scale)
