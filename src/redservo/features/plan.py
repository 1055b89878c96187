"""How a :class:`~redservo.task.VisualTask` evaluates its terms (internal), fixed once at
construction.

Consecutive terms that are plain :class:`~redservo.features.point.PointFeature` s of the
same target form a *point group*: one projection of all their points
(:func:`redservo.kernels.features.points_measure`) and one stacked interaction matrix
(:func:`~redservo.kernels.features.points_interaction`) instead of one call per point.
Every other term is a *single*, evaluated by its own feature. Each component goes through
the same arithmetic as on the per-term path (the kernels loop over the points with the
per-point formulas; the depth options act element by element), so the results are the
same to the bit; ``tests/test_task.py`` checks it against the per-term features.

The poses ``cMo`` handed to :func:`measure` are the task's own (built by
:meth:`redservo.scene.Scene.poses_in_camera` from validated transforms), so they are not
validated again; measured values coming from a user go through :func:`parts_of`, which
validates them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from operator import itemgetter
from typing import TYPE_CHECKING, NamedTuple, NoReturn, cast

import numpy as np

from redservo._validation import FloatArray, as_vector
from redservo.errors import ConfigurationError, GeometryError, ShapeError
from redservo.features.base import Feature, Measurement
from redservo.features.point import PointFeature
from redservo.kernels import lazy

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import features as _K
else:
    _K = lazy("features")

__all__ = [
    "Plan",
    "PointGroup",
    "Single",
    "depth_option",
    "interaction",
    "make_plan",
    "measure",
    "parts_of",
    "raise_behind",
    "single_group",
]


class PointGroup(NamedTuple):
    """Point features ``j0:j1`` of one target: rows ``a:b`` of ``s`` (2 per point)."""

    target: int
    """Index of the target in :attr:`Plan.targets`."""
    target_name: str
    a: int
    b: int
    j0: int
    j1: int
    points: FloatArray
    """(N, 3) the points in the object frame (m), C-contiguous."""
    star: FloatArray | None
    """(N,) their inverse depths at the desired pose (1/m), when known."""
    features: tuple[Feature, ...]
    split: Callable[[FloatArray], tuple[FloatArray, ...]]
    """The inverse depths (N,) to the per-term tuple of (1,) arrays (views)."""


class Single(NamedTuple):
    """Term ``j``, rows ``a:b`` of ``s``, evaluated by its feature."""

    target: int
    a: int
    b: int
    j: int
    feature: Feature
    measure: Callable[[FloatArray], Measurement]
    star: FloatArray | None


class Plan(NamedTuple):
    """The distinct targets (in order of first use) and the segments, in term order."""

    targets: tuple[str, ...]
    segments: tuple[PointGroup | Single, ...]
    n_terms: int


def _alone(iz: FloatArray) -> tuple[FloatArray, ...]:
    return (iz,)


def make_plan(
    features: Sequence[Feature],
    targets: Sequence[str],
    sizes: Sequence[int],
    stars: Sequence[FloatArray] | None,
) -> Plan:
    """Group the terms (features, their target names and sizes; ``stars`` the desired
    inverse-depth parameters per term, if known)."""
    names = tuple(dict.fromkeys(targets))
    offsets = np.cumsum((0, *sizes)).tolist()
    segs: list[PointGroup | Single] = []
    j, n = 0, len(features)
    while j < n:
        j1 = j
        while (
            j1 < n
            and type(features[j1]) is PointFeature
            and targets[j1] == targets[j]
            and (stars is None or stars[j1].shape == (1,))
        ):
            j1 += 1
        ti = names.index(targets[j])
        if j1 > j:
            pts = np.ascontiguousarray(
                np.stack([cast(PointFeature, f).point_o for f in features[j:j1]]), dtype=float
            )
            star = None if stars is None else np.concatenate(stars[j:j1])
            feats = tuple(features[j:j1])
            split = _alone if j1 == j + 1 else itemgetter(*(slice(i, i + 1) for i in range(j1 - j)))
            segs.append(
                PointGroup(ti, names[ti], offsets[j], offsets[j1], j, j1, pts, star, feats, split)
            )
            j = j1
        else:
            f = features[j]
            star1 = None if stars is None else stars[j]
            segs.append(Single(ti, offsets[j], offsets[j + 1], j, f, f._trusted_measure(), star1))
            j += 1
    return Plan(names, tuple(segs), n)


def single_group(plan: Plan) -> PointGroup | None:
    """The plan's only segment when it is a point group (the task's hot path), else None."""
    seg = plan.segments[0]
    return seg if len(plan.segments) == 1 and type(seg) is PointGroup else None


def raise_behind(group: PointGroup, bad: int, cMo: FloatArray) -> NoReturn:
    """Raise the error of point ``bad`` of ``group``, at or behind the camera at ``cMo``."""
    group.features[bad]._measure_trusted(cMo)  # raises the point's own message
    raise GeometryError(f"point {group.j0 + bad} is at or behind the camera plane")


def depth_option(
    d: FloatArray, star: FloatArray | None, depth: str, depth_scale: float
) -> FloatArray:
    """The inverse depths ``L`` uses: the measured ``d``, the desired ``star`` or their mean
    (``depth``), divided by ``depth_scale`` (``Ẑ = depth_scale · Z``).

    Raises:
        ConfigurationError: ``depth_scale`` is not positive and finite.
    """
    if depth != "current" and star is not None:
        d = star if depth == "desired" else 0.5 * (d + star)
    if depth_scale != 1.0:
        scale = float(depth_scale)
        if not (math.isfinite(scale) and scale > 0.0):
            raise ConfigurationError(
                f"depth_scale must be positive and finite, got {depth_scale!r}"
            )
        d = d / scale
    return d


def measure(
    plan: Plan, poses: Sequence[FloatArray]
) -> tuple[FloatArray, tuple[FloatArray, ...], list[FloatArray]]:
    """``(s, inv_depth per term, inverse depths per segment)`` at the task's own ``poses``
    (one ``cMo`` per target).

    Raises:
        GeometryError: a feature is invalid at its pose (the first one, in term order).
    """
    s_parts: list[FloatArray] = []
    parts: list[FloatArray] = []
    inv: list[FloatArray] = []
    for seg in plan.segments:
        cMo = poses[seg.target]
        if type(seg) is PointGroup:
            s, iz, bad = _K.points_measure(cMo, seg.points)
            if bad >= 0:
                raise_behind(seg, bad, cMo)
            s_parts.append(s)
            parts.append(iz)
            inv.extend(seg.split(iz))
        else:
            meas = seg.measure(cMo)  # type: ignore[union-attr]
            s_parts.append(meas.s)
            parts.append(meas.inv_depth)
            inv.append(meas.inv_depth)
    if len(s_parts) == 1:
        s = (
            s_parts[0]
            if type(plan.segments[0]) is PointGroup
            else np.array(s_parts[0], dtype=float)
        )
    else:
        s = np.asarray(np.concatenate(s_parts), dtype=float)
    return s, tuple(inv), parts


def parts_of(plan: Plan, inv_depth: Sequence[FloatArray]) -> list[FloatArray]:
    """The inverse depths per segment from a user's per-term ``inv_depth`` (validated for the
    point groups; a single's feature checks its own).

    Raises:
        ShapeError: not one entry per term, or a point's entry is not one finite number.
    """
    if len(inv_depth) != plan.n_terms:
        raise ShapeError(
            f"inv_depth needs one entry per term ({plan.n_terms}), got {len(inv_depth)}",
            argument="inv_depth",
        )
    parts: list[FloatArray] = []
    for seg in plan.segments:
        if type(seg) is not PointGroup:
            parts.append(inv_depth[seg.j])  # type: ignore[union-attr]
            continue
        n = seg.j1 - seg.j0
        given = inv_depth[seg.j0 : seg.j1]
        iz = None
        try:
            if list(map(len, given)) == [1] * n:
                iz = np.concatenate(given)
        except (TypeError, ValueError):
            pass
        if (
            iz is None
            or iz.ndim != 1
            or iz.dtype != np.float64
            or not math.isfinite(float(iz.sum()))
        ):
            iz = np.array([as_vector(given[k], f"inv_depth[{seg.j0 + k}]", 1)[0] for k in range(n)])
        parts.append(iz)
    return parts


def interaction(
    plan: Plan, s: FloatArray, parts: Sequence[FloatArray], depth: str, depth_scale: float
) -> FloatArray:
    """The stacked ``L`` (k, 6) at ``s`` with the inverse depths ``parts`` (per segment),
    the depth option (``"current"``, ``"desired"``, ``"mean"``) and the depth-estimate
    factor ``Ẑ = depth_scale · Z``."""
    out: list[FloatArray] = []
    for seg, d in zip(plan.segments, parts, strict=True):
        d = depth_option(d, seg.star, depth, depth_scale)
        if type(seg) is PointGroup:
            out.append(_K.points_interaction(s[seg.a : seg.b], d))
        else:
            out.append(seg.feature.interaction(s[seg.a : seg.b], d))  # type: ignore[union-attr]
    return out[0] if len(out) == 1 else np.vstack(out)
