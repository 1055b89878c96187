"""Straight lines ``(ρ, θ)``: the cylinder's two limbs, or a thin line.

Image lines use the features' convention (:mod:`redservo.features.line`):
``x cos θ + y sin θ = ρ`` in *undistorted normalized* coordinates, θ in (-π, π].
``(ρ, θ)`` and ``(-ρ, θ + π)`` are the same line; :func:`orient_like` picks the
one nearer a reference, which is how the orientation stays consistent between
frames (and equal to the ideal feature's when the reference is the truth).

:func:`refine_line` measures a line near a prediction (edge detection along
normals, then a line fit):

1. sample the predicted line every ``step_px`` pixels inside the image;
2. at each sample read the image along the line's normal, ``±search_px``
   pixels at half-pixel steps (bilinear interpolation, ``cv2.remap``);
3. ``mode="edge"`` (a limb, the boundary of the cylinder's band): the edge is
   the strongest gradient of the expected sign (learnt on the first frame), and
   its sub-pixel position the crossing of the mid level between the gray levels
   2-3 px on either side; ``mode="ridge"`` (a thin bright or dark stripe): the
   intensity-weighted centre of the stripe around its peak;
4. map the edge points to undistorted normalized coordinates and fit a line by
   total least squares, twice dropping points farther than max(3 robust σ,
   0.5 px) from the fit.

:func:`find_lines` detects lines with no prediction (Canny + Hough), for a first
frame from a real camera.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.features.base import wrap_angle
from redservo.vision.optics import Optics, require_cv2

__all__ = ["LineMeasurement", "LineMode", "find_lines", "orient_like", "profiles", "refine_line"]

LineMode = Literal["edge", "ridge"]
_STEP = 0.5
"""Profile sampling step along the normal (pixels)."""


class LineMeasurement(NamedTuple):
    """A measured image line."""

    rho: float
    """ρ (normalized units)."""
    theta: float
    """θ (rad), in (-π, π]."""
    n_points: int
    """Edge points kept by the fit."""
    rms_px: float
    """RMS distance (pixels) of the kept points to the line."""
    sign: float
    """Sign of the edge gradient along the normal (+1 dark-to-bright), or the ridge polarity."""


def orient_like(rho: float, theta: float, ref_rho: float, ref_theta: float) -> tuple[float, float]:
    """Return ``(ρ, θ)`` or ``(-ρ, θ + π)``, whichever is nearer ``(ref_ρ, ref_θ)``; θ in (-π, π]."""
    a = (rho, float(wrap_angle(theta)))
    b = (-rho, float(wrap_angle(theta + np.pi)))
    da = abs(float(wrap_angle(a[1] - ref_theta))) + abs(a[0] - ref_rho)
    db = abs(float(wrap_angle(b[1] - ref_theta))) + abs(b[0] - ref_rho)
    return a if da <= db else b


def _samples(
    optics: Optics, rho: float, theta: float, step_px: float, margin: float
) -> tuple[FloatArray, FloatArray]:
    """Pixels (K, 2) on the line inside the image (with ``margin``) and unit normals (K, 2)."""
    cam = optics.camera
    h, w = optics.shape
    n = np.array([np.cos(theta), np.sin(theta)])
    d = np.array([-n[1], n[0]])
    border = np.concatenate(
        [
            np.stack([np.linspace(0, w, 9), np.zeros(9)], 1),
            np.stack([np.linspace(0, w, 9), np.full(9, h)], 1),
            np.stack([np.zeros(9), np.linspace(0, h, 9)], 1),
            np.stack([np.full(9, w), np.linspace(0, h, 9)], 1),
        ]
    )
    xy = optics.to_normalized(border)
    p0 = rho * n
    t_ext = (xy - p0) @ d
    t_lo, t_hi = float(t_ext.min()), float(t_ext.max())
    dt = step_px / max(cam.px, cam.py)
    t = np.arange(t_lo, t_hi, dt)
    pts = p0 + t[:, None] * d
    eps = 0.5 / max(cam.px, cam.py)
    uv = optics.to_pixel(pts)
    nu = optics.to_pixel(pts + eps * n) - optics.to_pixel(pts - eps * n)
    nu /= np.maximum(np.linalg.norm(nu, axis=1, keepdims=True), 1e-300)
    ok = (uv[:, 0] >= margin) & (uv[:, 0] <= w - margin) & (uv[:, 1] >= margin)
    ok &= uv[:, 1] <= h - margin
    return uv[ok], nu[ok]


def profiles(image: NDArray[np.uint8], uv: FloatArray, d: FloatArray, s: FloatArray) -> FloatArray:
    """Gray levels (K, S) sampled (bilinear) at ``uv + s d`` (pixels; ``uv``, ``d`` (K, 2),
    ``s`` (S,)): the profiles across K edges, sampled every :data:`_STEP` px."""
    cv2 = require_cv2()
    pos = uv[:, None, :] + s[None, :, None] * d[:, None, :] - 0.5  # OpenCV: centres on integers
    return np.asarray(
        cv2.remap(
            image.astype(np.float32),
            pos[..., 0].astype(np.float32),
            pos[..., 1].astype(np.float32),
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_REPLICATE,
        ),
        dtype=float,
    )


def _edge_offsets(
    prof: FloatArray, s: FloatArray, sign: float, blur_px: float
) -> tuple[FloatArray, float]:
    """Sub-pixel edge offsets (K,) along each profile (NaN where no edge), and the sign used."""
    g = np.gradient(prof, axis=1)
    if sign == 0.0:
        pos, neg = g.max(axis=1), -g.min(axis=1)
        sign = 1.0 if np.median(pos) >= np.median(neg) else -1.0
    sg = sign * g
    k = np.argmax(sg, axis=1)
    peak = sg[np.arange(prof.shape[0]), k]
    half = int(np.ceil((2.0 + 2.0 * blur_px) / _STEP))
    out = np.full(prof.shape[0], np.nan)
    strong = peak > 0.25 * np.median(peak)
    n = prof.shape[1]
    for i in np.flatnonzero(strong & (k - half - 2 >= 0) & (k + half + 2 < n)):
        row = prof[i]
        lo = float(row[k[i] - half - 2 : k[i] - half + 1].mean())
        hi = float(row[k[i] + half : k[i] + half + 3].mean())
        mid = 0.5 * (lo + hi)
        seg = sign * (row[k[i] - half : k[i] + half + 1] - mid)
        cross = np.flatnonzero((seg[:-1] < 0.0) & (seg[1:] >= 0.0))
        if cross.size == 0:
            continue
        j = int(cross[np.argmin(np.abs(cross + 0.5 - half))])
        a, b = seg[j], seg[j + 1]
        out[i] = s[k[i] - half + j] + _STEP * (-a / (b - a))
    return out, sign


def _ridge_offsets(
    prof: FloatArray, s: FloatArray, sign: float, width: float
) -> tuple[FloatArray, float]:
    """Sub-pixel stripe centres (K,) along each profile (NaN where none), and the polarity used."""
    base = np.median(np.concatenate([prof[:, :4], prof[:, -4:]], axis=1), axis=1, keepdims=True)
    if sign == 0.0:
        up = float(np.median(prof.max(axis=1) - base[:, 0]))
        down = float(np.median(base[:, 0] - prof.min(axis=1)))
        sign = 1.0 if up >= down else -1.0
    wts = sign * (prof - base)
    k = np.argmax(wts, axis=1)
    half = int(np.ceil(width / _STEP))
    out = np.full(prof.shape[0], np.nan)
    for i in range(prof.shape[0]):
        lo, hi = max(k[i] - half, 0), min(k[i] + half + 1, prof.shape[1])
        wi = wts[i, lo:hi]
        if wi.sum() > 0.0:
            out[i] = float((wi * s[lo:hi]).sum() / wi.sum())
    return out, sign


def _fit(xy: FloatArray, scale: float) -> tuple[FloatArray, float, FloatArray]:
    """Total-least-squares line: unit normal, ρ, and residuals (pixels)."""
    m = xy.mean(axis=0)
    _, _, Vt = np.linalg.svd(xy - m, full_matrices=False)
    n = Vt[-1]
    rho = float(n @ m)
    return n, rho, (xy @ n - rho) * scale


def refine_line(
    image: NDArray[np.uint8],
    optics: Optics,
    rho: float,
    theta: float,
    *,
    mode: LineMode = "edge",
    sign: float = 0.0,
    search_px: float = 12.0,
    step_px: float = 6.0,
    min_points: int = 10,
    blur_px: float = 0.0,
    width_px: float = 3.0,
) -> tuple[LineMeasurement | None, str]:
    """Measure the line near the prediction ``(ρ, θ)``; return ``(measurement, reason)``.

    Args:
        image: (H, W) uint8 grayscale image.
        optics: Camera intrinsics and distortion.
        rho: Predicted ρ (normalized units).
        theta: Predicted θ (rad).
        mode: ``"edge"`` (boundary of a region) or ``"ridge"`` (thin stripe).
        sign: Expected gradient sign along the normal (edge) or stripe polarity (ridge);
            0 = decide from this image.
        search_px: Half-length (pixels) of the search along the normal.
        step_px: Spacing (pixels) of the samples along the line.
        min_points: Fewest edge points for a fit.
        blur_px: Standard deviation of the image blur (pixels); widens the edge window.
        width_px: Stripe width (pixels) for ``mode="ridge"``.

    The measured line is oriented like the prediction (:func:`orient_like`).
    """
    require_cv2()  # a clear error when OpenCV is missing
    if mode not in ("edge", "ridge"):
        raise ConfigurationError(f"line mode must be 'edge' or 'ridge', got {mode!r}")
    uv, nu = _samples(optics, rho, theta, step_px, search_px + 2.0)
    if uv.shape[0] < min_points:
        return None, f"the line has fewer than {min_points} samples inside the image"
    s = np.arange(-search_px, search_px + 1e-9, _STEP)
    prof = profiles(image, uv, nu, s)
    if mode == "edge":
        off, used = _edge_offsets(prof, s, sign, blur_px)
    else:
        off, used = _ridge_offsets(prof, s, sign, width_px + 2.0 + 3.0 * blur_px)
    ok = np.isfinite(off)
    if int(ok.sum()) < min_points:
        return None, f"fewer than {min_points} edge points found along the line"
    pts = optics.to_normalized(uv[ok] + off[ok, None] * nu[ok])
    scale = max(optics.camera.px, optics.camera.py)
    keep = np.ones(pts.shape[0], dtype=bool)
    for _ in range(3):
        n, r, res = _fit(pts[keep], scale)
        full = (pts @ n - r) * scale
        mad = float(np.median(np.abs(full[keep] - np.median(full[keep]))))
        keep = np.abs(full) <= max(3.0 * 1.4826 * mad, 0.5)
        if int(keep.sum()) < min_points:
            return None, "the edge points do not lie on a line"
    n, r, res = _fit(pts[keep], scale)
    meas_rho, meas_theta = orient_like(r, float(np.arctan2(n[1], n[0])), rho, theta)
    rms = float(np.sqrt(np.mean(res**2)))
    return LineMeasurement(meas_rho, meas_theta, int(keep.sum()), rms, used), ""


def find_lines(
    image: NDArray[np.uint8], optics: Optics, n_lines: int, *, min_votes: int = 80
) -> list[tuple[float, float]]:
    """Up to ``n_lines`` strongest straight edges ``(ρ, θ)`` (normalized), by Canny + Hough.

    For a first frame with no prediction; refine each with :func:`refine_line`.
    Lines closer than 3 px and 2 degrees to a stronger one are skipped. The
    distortion is ignored here (the refinement undoes it).
    """
    cv2 = require_cv2()
    edges = cv2.Canny(image, 30, 90)
    found = cv2.HoughLines(edges, 1, np.pi / 360, min_votes)
    cam = optics.camera
    out: list[tuple[float, float]] = []
    kept_px: list[tuple[float, float]] = []
    for r_px, phi in [] if found is None else found[:, 0, :]:
        r_c = float(r_px) + 0.5 * (np.cos(phi) + np.sin(phi))  # pixel centres at +0.5
        if any(
            abs(r_c - r0) < 3.0 and abs(float(wrap_angle(phi - p0))) < np.deg2rad(2)
            for r0, p0 in kept_px
        ):
            continue
        kept_px.append((r_c, float(phi)))
        nx, ny = cam.px * np.cos(phi), cam.py * np.sin(phi)
        nn = float(np.hypot(nx, ny))
        rho = (r_c - cam.u0 * np.cos(phi) - cam.v0 * np.sin(phi)) / nn
        out.append((float(rho), float(np.arctan2(ny, nx))))
        if len(out) == n_lines:
            break
    return out
