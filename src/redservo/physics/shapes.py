"""Spheres, cylinders and lines measured in a MuJoCo image by their edges, whatever the shading.

A cylinder's limbs are the image sensor's (:func:`redservo.vision.terms.measure_lines`) with
their edge signs from the dark paint (:func:`limb_signs`); a line is drawn as a thin rod
whose axis is found from its two limbs (:func:`line_from_limbs`, :func:`measure_rod`).

MuJoCo draws a sphere shaded by its lights and shadowed by the arm, on a background that
may change along its outline (the sky, the arm, another object). A threshold or a
coverage from global gray levels would move the outline with the shading; here each
point of the outline is found with its *own* levels: :func:`measure_sphere_edges`

1. casts ``n_rays`` rays from the predicted centre (the last measurement, or the true
   projection on a first frame) and reads the image along each (bilinear, half-pixel
   steps) from a quarter of the predicted radius to 1.5 radii + 8 px beyond;
2. on each ray takes the strongest edge of the expected sign (dark inside for the dark
   matte sphere of :mod:`redservo.physics.scenes`, decided from the image when 0) and
   its sub-pixel position where the profile crosses the level midway between the
   levels 2-3 px inside and outside (:func:`redservo.vision.lines.refine_line`'s
   edge rule), dropping edges of less than :data:`MIN_CONTRAST` gray levels and those
   within 4 px of the image border (a sphere cut by the border is fitted to its visible
   arc, while at least ``min_fraction`` of the rays find it);
3. maps the edge points to undistorted pixels and fits an ellipse
   (``cv2.fitEllipseDirect``), twice dropping points farther than
   max(3 robust σ, 0.5 px) from it; then casts the rays again from the fitted centre
   (``passes`` times in all), so that a prediction a fraction of the radius off costs
   nothing.

The ellipse's centre, area ``π A B`` and normalized centred moments (``A, B`` semi-axes,
:func:`redservo.vision.ellipse.ellipse_moments`) are those of
:func:`redservo.features.sphere.sphere_ellipse`; the feature's variant picks
``(xc, yc, a)`` or ``(xc, yc, n20, n11, n02)``.

Units: pixels for the search, normalized image units for the result, gray levels 0-255.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import GeometryError
from redservo.features import CylinderFeature, SphereFeature
from redservo.vision.ellipse import EllipseMeasurement, pixel_ellipse
from redservo.vision.lines import _edge_offsets, orient_like, profiles
from redservo.vision.optics import Optics, require_cv2
from redservo.vision.render import Renderer
from redservo.vision.terms import TermState, measure_lines

__all__ = [
    "MIN_CONTRAST",
    "RodTerm",
    "limb_signs",
    "line_from_limbs",
    "measure_rod",
    "measure_sphere_edges",
    "measure_sphere_term",
    "predicted_ellipse",
    "sphere_value",
]

MIN_CONTRAST = 20.0
"""Smallest step (gray levels) between the inside and the outside of an edge point."""

_STEP = 0.5
"""Sampling step along a ray (pixels)."""


def predicted_ellipse(s: FloatArray, optics: Optics) -> tuple[FloatArray, float]:
    """Centre (2,) and equivalent radius ``sqrt(A B)`` (pixels) of a sphere feature's
    value ``s``: ``(xc, yc, a)`` or ``(xc, yc, n20, n11, n02)`` (normalized units)."""
    cam = optics.camera
    if s.shape[0] == 3:
        r = float(np.sqrt(max(s[2], 0.0) / np.pi))
    else:  # n20 n02 - n11² = (A B)² / 16
        r = float(np.sqrt(4.0 * np.sqrt(max(s[2] * s[4] - s[3] ** 2, 0.0))))
    uv = optics.to_pixel(np.asarray(s[:2], dtype=float))
    return np.asarray(uv, dtype=float), r * float(np.sqrt(cam.px * cam.py))


def _edge_points(
    image: NDArray[np.uint8],
    centre: FloatArray,
    radius: float,
    n_rays: int,
    sign: float,
    blur_px: float,
) -> tuple[FloatArray, float]:
    """Sub-pixel edge points (K, 2) (pixels, distorted image) along rays, and the sign used."""
    require_cv2()  # a clear error when OpenCV is missing
    ang = np.linspace(0.0, 2.0 * np.pi, n_rays, endpoint=False)
    d = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    s = np.arange(0.25 * radius, 1.5 * radius + 8.0, _STEP)
    prof = profiles(image, np.broadcast_to(centre, d.shape), d, s)
    off, used = _edge_offsets(prof, s, sign, blur_px)
    step = _contrast(prof, s, off)
    h, w = image.shape
    far = centre[None, :] + (np.nan_to_num(off) + 4.0)[:, None] * d  # 4 px outside the edge
    inside = (
        (far[:, 0] >= 1.0) & (far[:, 0] <= w - 1.0) & (far[:, 1] >= 1.0) & (far[:, 1] <= h - 1.0)
    )
    ok = np.isfinite(off) & (used * step >= MIN_CONTRAST) & inside
    return centre[None, :] + off[ok, None] * d[ok], used


def _contrast(prof: FloatArray, s: FloatArray, off: FloatArray) -> FloatArray:
    """Outside minus inside level (gray levels) 2-3 px either side of each edge (NaN: none,
    or a window past the profile's ends)."""
    n = prof.shape[1]
    k = np.searchsorted(s, np.nan_to_num(off, nan=s[0]))
    lo = np.clip(k[:, None] + np.arange(-6, -3), 0, n - 1)
    hi = np.clip(k[:, None] + np.arange(4, 7), 0, n - 1)
    step = np.take_along_axis(prof, hi, axis=1).mean(axis=1) - np.take_along_axis(
        prof, lo, axis=1
    ).mean(axis=1)
    ok = np.isfinite(off) & (k - 6 >= 0) & (k + 6 <= n - 1)
    return np.where(ok, step, np.nan)


def _fit(
    und: FloatArray,
) -> tuple[tuple[float, float], tuple[float, float], float, NDArray[np.bool_]]:
    """Robust ellipse fit of undistorted pixel points (K, 2): centre, full axes, angle (deg),
    and the points kept."""
    cv2 = require_cv2()
    keep = np.ones(und.shape[0], dtype=bool)
    for _ in range(3):
        (cu, cv), (d1, d2), ang = cv2.fitEllipseDirect(und[keep].astype(np.float32))
        c, s_ = np.cos(np.deg2rad(ang)), np.sin(np.deg2rad(ang))
        dx, dy = und[:, 0] - cu, und[:, 1] - cv
        x, y = c * dx + s_ * dy, -s_ * dx + c * dy
        a, b = max(d1 / 2.0, 1e-9), max(d2 / 2.0, 1e-9)
        res = (np.hypot(x / a, y / b) - 1.0) * np.sqrt(a * b)  # ≈ distance (px)
        mad = float(np.median(np.abs(res[keep] - np.median(res[keep]))))
        keep = np.abs(res) <= max(3.0 * 1.4826 * mad, 0.5)
        if int(keep.sum()) < 8:
            break
    return (cu, cv), (d1, d2), float(ang), keep


def measure_sphere_edges(
    image: NDArray[np.uint8],
    optics: Optics,
    centre_px: FloatArray,
    radius_px: float,
    *,
    sign: float = 0.0,
    blur_px: float = 0.0,
    n_rays: int = 96,
    passes: int = 2,
    min_fraction: float = 0.5,
) -> tuple[EllipseMeasurement | None, str]:
    """The ellipse of the sphere near ``centre_px`` (2,) of about ``radius_px`` (module
    docstring); ``sign`` +1 for a dark sphere on a brighter background, -1 for a bright
    one, 0 to decide from the image. None and why when fewer than ``min_fraction`` of the
    rays find its edge."""
    cam = optics.camera
    centre = np.asarray(centre_px, dtype=float)
    radius = max(float(radius_px), 3.0)
    if not np.all(np.isfinite(centre)) or not np.isfinite(radius):
        return None, "no prediction of the sphere's ellipse"
    for _ in range(passes):
        pts, sign = _edge_points(image, centre, radius, n_rays, sign, blur_px)
        if pts.shape[0] < max(min_fraction * n_rays, 8):
            return None, (
                f"the sphere's edge found on {pts.shape[0]} of {n_rays} rays "
                "(hidden, out of the image or no contrast)"
            )
        xy = optics.to_normalized(pts)
        und = xy * [cam.px, cam.py] + [cam.u0, cam.v0]
        (cu, cv), (d1, d2), ang, keep = _fit(und)
        if int(keep.sum()) < min_fraction * n_rays:
            return None, "the sphere's edge points do not lie on an ellipse"
        centre = np.asarray(
            optics.to_pixel(np.array([(cu - cam.u0) / cam.px, (cv - cam.v0) / cam.py]))
        )
        radius = 0.5 * float(np.sqrt(d1 * d2))
    meas = pixel_ellipse(cam, (cu, cv), 0.5 * d1, 0.5 * d2, ang, (centre[0], centre[1]))
    return meas, ""


def sphere_value(meas: EllipseMeasurement, feature: SphereFeature) -> FloatArray:
    """The feature's ``s`` from a measured ellipse, per its variant."""
    if feature.variant == "moments":
        return np.array([meas.xc, meas.yc, meas.n20, meas.n11, meas.n02])
    return np.array([meas.xc, meas.yc, meas.area])


def measure_sphere_term(
    image: NDArray[np.uint8],
    optics: Optics,
    st: TermState,
    feature: SphereFeature,
    truth: FloatArray | None,
    blur_px: float = 0.0,
) -> tuple[FloatArray | None, str]:
    """A sphere term's ``s`` in a MuJoCo image, or None and why.

    The prediction is the true value on a first frame, then the last value moved at
    constant velocity (the last one alone after a loss); the sphere is dark on a lighter
    background (:data:`redservo.physics.scenes.SHAPE_RGBA`)."""
    if st.s is None:
        if truth is None:
            return None, "not visible on the first frame"
        pred = np.asarray(truth, dtype=float)
    elif st.prev_s is not None and st.lost == 0:
        pred = 2.0 * st.s - st.prev_s
    else:
        pred = st.s
    centre, radius = predicted_ellipse(pred, optics)
    meas, why = measure_sphere_edges(image, optics, centre, radius, sign=1.0, blur_px=blur_px)
    if meas is None:
        return None, why
    st.uv = meas.uv
    return sphere_value(meas, feature), ""


def limb_signs(s: FloatArray) -> list[float]:
    """The edge signs of a dark cylinder's two limbs ``s = (ρ1, θ1, ρ2, θ2)``: +1 where the
    image goes from dark to light along the limb's normal ``(cos θ, sin θ)``.

    The band lies between the limbs: around the midpoint ``m`` of the feet of the image
    centre on both limbs, so limb ``k``'s sign is +1 when ``m`` is on its low side
    (``m · n_k < ρ_k``). Given to the edge refinement, it keeps a narrow band's limb from
    locking onto the other limb, whose edge of the opposite sign lies in the same search
    window (:func:`redservo.vision.lines.refine_line`)."""
    n = [np.array([np.cos(s[1]), np.sin(s[1])]), np.array([np.cos(s[3]), np.sin(s[3])])]
    feet = [s[0] * n[0], s[2] * n[1]]  # feet of (0, 0) on each limb (normalized)
    m = 0.5 * (feet[0] + feet[1])
    return [1.0 if float(m @ n[k]) < float(s[2 * k]) else -1.0 for k in range(2)]


def line_from_limbs(limbs: FloatArray, signs: list[float]) -> tuple[float, float]:
    """The image ``(ρ, θ)`` of a rod's axis from its two limbs ``(ρ1, θ1, ρ2, θ2)`` and their
    edge signs (:func:`limb_signs`).

    Limb ``k`` is the plane ``N_k · X = 0`` through the optical centre, ``N_k = (cos θk,
    sin θk, −ρk)``; the rod lies where ``sign_k N̂_k · X < 0`` for both. The mirror symmetry
    of a cylinder about the plane through the optical centre and its axis makes that plane
    the bisector of the wedge, ``(M1 − M2) · X = 0`` with ``M_k = sign_k N̂_k``: exact for any
    radius. θ in (-π, π]; the caller orients the pair (:func:`redservo.vision.lines.orient_like`).
    """
    m = []
    for k in range(2):
        rho, theta = float(limbs[2 * k]), float(limbs[2 * k + 1])
        N = np.array([np.cos(theta), np.sin(theta), -rho])
        m.append(signs[k] * N / np.linalg.norm(N))
    a, b, c = m[0] - m[1]
    return float(-c / np.hypot(a, b)), float(np.arctan2(b, a))


@dataclass
class RodTerm:
    """A line term drawn as a rod: the rod's limbs as a cylinder feature, tracked in ``state``."""

    limbs: CylinderFeature
    target: str
    state: TermState = field(default_factory=lambda: TermState("cylinder"))


def measure_rod(
    image: NDArray[np.uint8],
    renderer: Renderer,
    rod: RodTerm,
    cMo: FloatArray | None,
    ref: FloatArray | None,
) -> tuple[FloatArray | None, str]:
    """A line's ``(ρ, θ)`` in a MuJoCo image, from the two limbs of its rod, or None and why.

    The limbs are predicted from ``cMo`` (the object's pose, on a first frame) then tracked
    (:func:`redservo.vision.terms.measure_lines`, edge signs from :func:`limb_signs`); the
    axis is :func:`line_from_limbs`, oriented like ``ref`` (the last value or the truth)."""
    st = rod.state
    truth = None
    if st.s is None:
        if cMo is None:
            return None, "not visible on the first frame"
        try:
            truth = rod.limbs.measure(cMo).s
        except GeometryError as exc:
            return None, str(exc)
        st.signs = limb_signs(truth)
    s, why = measure_lines(image, renderer, st, truth)
    if s is None:
        st.lost += 1
        return None, f"the rod's {why}"
    st.prev_s, st.s, st.lost = st.s, s, 0
    rho, theta = line_from_limbs(s, st.signs)
    if ref is not None:
        rho, theta = orient_like(rho, theta, float(ref[0]), float(ref[1]))
    return np.array([rho, theta]), ""
