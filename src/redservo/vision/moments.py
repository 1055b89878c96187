"""Moment features from detected dots, and moments of a dense region.

:func:`dot_moment_features` turns detected dots (normalized coordinates) into
the six MC05 features ``(xn, yn, an, α, r1, r2)`` of a
:class:`~redservo.features.moments.MomentFeatures` with exactly its definitions
(:func:`~redservo.features.moments.moment_features`), and hands the dots'
moments to that feature so that its interaction matrix is evaluated at the
*measured* moments. (``MomentFeatures.interaction`` looks the moments up in a
small cache filled by ``measure``; the image sensor fills it through
:func:`remember_moments` — the one place this package reaches into the
feature's internals.)

:func:`region_moments` measures a dense region instead (a blob of the image,
weighted by its coverage): ``m00`` is then its area, the centred moments are
integrals, and the matching interaction matrix is the region one
(``centred_moment_interaction(..., delta=1, eps=4)``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray, as_matrix
from redservo.errors import GeometryError
from redservo.features.moments import ImageMoments, MomentFeatures, image_moments, moment_features
from redservo.vision.optics import Optics

__all__ = ["dot_moment_features", "region_moments", "remember_moments"]

_ORDER = 4


def remember_moments(feature: MomentFeatures, s: FloatArray, mom: ImageMoments) -> None:
    """Record the moments ``mom`` behind the value ``s`` so ``feature.interaction(s, ...)`` uses them."""
    cache = getattr(feature, "_cache", None)
    if cache is None:  # pragma: no cover - a future MomentFeatures without the cache
        return
    key = np.asarray(s, dtype=float).tobytes()
    cache[key] = (np.asarray(s, dtype=float).copy(), mom)
    cache.move_to_end(key)
    while len(cache) > 32:
        cache.popitem(last=False)


def dot_moment_features(xy: ArrayLike, feature: MomentFeatures) -> FloatArray:
    """The six moment features (6,) of the dots ``xy`` (N, 2), normalized coordinates.

    Uses the feature's normalization (``a*``, ``Z*``) and rotation features, and
    records the dots' moments for its interaction matrix (:func:`remember_moments`).

    Raises:
        GeometryError: too few dots or degenerate moments (see MomentFeatures).
    """
    pts = as_matrix(xy, "xy", None, 2)
    if pts.shape[0] < 3:
        raise GeometryError(f"moment features need at least 3 dots, got {pts.shape[0]}")
    mom = image_moments(pts)
    s = moment_features(
        mom,
        area_star=feature.desired_area,
        depth_star=feature.desired_depth,
        rotation_features=feature.rotation_features,
    )
    remember_moments(feature, s, mom)
    return s


def region_moments(
    weights: NDArray[np.floating], optics: Optics, origin: tuple[int, int] = (0, 0)
) -> ImageMoments:
    """Moments up to order 4 of a dense region, in undistorted normalized coordinates.

    Args:
        weights: (h, w) coverage of each pixel by the region (1 inside, 0 outside,
            fractions on the edge; e.g. a binary mask as 0/1).
        optics: Camera intrinsics and distortion (each pixel at its undistorted
            position, with its own area).
        origin: ``(row, col)`` of ``weights[0, 0]`` in the image.

    Returns:
        :class:`~redservo.features.moments.ImageMoments` whose ``mu`` holds the
        centred moment integrals, ``mu[0, 0]`` being the area (normalized
        units²); ``n`` is 1 (a region has no point count).

    Raises:
        GeometryError: the region is empty.
    """
    w = np.asarray(weights, dtype=float)
    r0, c0 = origin
    rows, cols = slice(r0, r0 + w.shape[0]), slice(c0, c0 + w.shape[1])
    x, y = optics.grid(rows, cols)
    dA = w * optics.pixel_area(rows, cols)
    m00 = float(dA.sum())
    if m00 <= 0.0:
        raise GeometryError("the region is empty (zero area); no moments")
    xg, yg = float((dA * x).sum()) / m00, float((dA * y).sum()) / m00
    dx, dy = (x - xg).ravel(), (y - yg).ravel()
    px = np.vander(dx, _ORDER + 1, increasing=True) * dA.ravel()[:, None]
    py = np.vander(dy, _ORDER + 1, increasing=True)
    mu = px.T @ py
    i, j = np.indices(mu.shape)
    mu[i + j > _ORDER] = 0.0
    return ImageMoments(1, xg, yg, mu)
