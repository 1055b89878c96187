"""Generated dot sequences with exact truth: the failure modes of real dot tracking.

:func:`dot_sequence` draws a 4-dot target moving over a scene, frame by frame,
with the exact centre of every dot (pixels, centre convention of
:mod:`redservo.vision.optics`: pixel ``(row i, col j)`` spans
``[j, j+1] x [i, i+1]``) and whether it is visible. Discs are drawn with their
exact area coverage (supersampled 8 x 8 per pixel), squares exactly (their
coverage is separable), motion blur by averaging the disc over 9 positions along
the frame's motion (the truth is the mid-exposure centre), then a Gaussian blur
(the optics), a multiplicative lighting gradient, Gaussian noise of ``noise``
gray levels and rounding to uint8.

Kinds (:data:`SEQUENCE_KINDS`):

* ``"nested"``: ViSP's 4-dot target: white dots in black squares on white paper
  that reaches the image border (a global threshold makes the paper one
  component holding the squares' holes);
* ``"bright_crossing"``: bright dots on a dark background; a mid-gray band
  (brighter than the global threshold, darker than the dots) that dots 0 and 3
  cross back and forth (each lies wholly on it for 8 frames each time);
* ``"bright_merge"``: the same with a band as bright as the dots: a dot on it or
  within 2 px of it is merged with it (not visible; 0-2 px away, it may still be
  separable), and must be re-acquired after;
* ``"motion_blur"``: the target runs around a circle at 3 px per frame per 120
  px of image height (12 px per frame at 640 x 480), blurred along the motion;
* ``"gradient"``: the lighting falls from 1 to 0.3 across the image;
* ``"occlusion"``: a background-coloured patch hides dot 2 for ``occlusion``
  frames (the dot is not visible), then it reappears;
* ``"digits"``: printed digits (``cv2.putText``, the dots' gray level) beside each dot.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.vision.optics import require_cv2

__all__ = ["SEQUENCE_KINDS", "DotSequenceFrame", "dot_sequence"]

SEQUENCE_KINDS = (
    "nested",
    "bright_crossing",
    "bright_merge",
    "motion_blur",
    "gradient",
    "occlusion",
    "digits",
)

_SS = 8  # supersampling per pixel side


class DotSequenceFrame(NamedTuple):
    """One generated frame and its truth."""

    image: NDArray[np.uint8]
    uv: FloatArray
    """(4, 2) exact dot centres (pixels)."""
    visible: NDArray[np.bool_]
    """(4,) dots wholly visible in this frame."""


def _disc_coverage(
    shape: tuple[int, int], u: float, v: float, r: float, motion: tuple[float, float]
) -> tuple[tuple[slice, slice], NDArray[np.float32]]:
    """Area coverage (0-1) of a disc centred at (u, v) of radius r, averaged along ``motion``."""
    H, W = shape
    reach = r + 0.5 * max(abs(motion[0]), abs(motion[1])) + 1
    c0, c1 = max(int(u - reach), 0), min(int(u + reach) + 2, W)
    r0, r1 = max(int(v - reach), 0), min(int(v + reach) + 2, H)
    sub = (np.arange(_SS) + 0.5) / _SS
    xs = (np.arange(c0, c1)[:, None] + sub[None, :]).ravel()
    ys = (np.arange(r0, r1)[:, None] + sub[None, :]).ravel()
    cov = np.zeros((ys.size, xs.size), np.float32)
    steps = np.linspace(-0.5, 0.5, 9) if motion != (0.0, 0.0) else np.zeros(1)
    for s in steps:
        du = xs - (u + s * motion[0])
        dv = ys - (v + s * motion[1])
        cov += (dv[:, None] ** 2 + du[None, :] ** 2 <= r * r).astype(np.float32)
    cov /= len(steps)
    cov = cov.reshape(r1 - r0, _SS, c1 - c0, _SS).mean(axis=(1, 3))
    return (slice(r0, r1), slice(c0, c1)), cov


def _paint_disc(
    img: NDArray[np.float32],
    uv: FloatArray,
    r: float,
    level: float,
    motion: tuple[float, float] = (0.0, 0.0),
) -> None:
    win, cov = _disc_coverage(img.shape, float(uv[0]), float(uv[1]), r, motion)
    img[win] = img[win] * (1.0 - cov) + level * cov


def _paint_square(img: NDArray[np.float32], u: float, v: float, half: float, level: float) -> None:
    H, W = img.shape
    cx = np.clip(np.minimum(np.arange(W) + 1, u + half) - np.maximum(np.arange(W), u - half), 0, 1)
    cy = np.clip(np.minimum(np.arange(H) + 1, v + half) - np.maximum(np.arange(H), v - half), 0, 1)
    cov = cy[:, None] * cx[None, :]
    img[:] = img * (1.0 - cov) + level * cov


def _target(k: int, kind: str, W: int, H: int, spacing: float) -> tuple[FloatArray, FloatArray]:
    """The 4 dot centres at frame k and their motion over the frame (pixels)."""
    base = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]) * 0.5 * spacing
    if kind == "motion_blur":
        rad, w = 0.18 * min(W, H), 3.0 * (min(W, H) / 120.0) / (0.18 * min(W, H))
        c = np.array([W / 2 + rad * np.cos(w * k), H / 2 + rad * np.sin(w * k)])
        vel = rad * w * np.array([-np.sin(w * k), np.cos(w * k)])
        return base + c, np.tile(vel, (4, 1))
    if kind in ("bright_crossing", "bright_merge"):
        phase = k % 120 if k % 120 < 60 else 120 - k % 120  # back and forth, 60 frames each way
        c = np.array([0.3 * W + 0.4 * W * phase / 60.0, H / 2 + 0.05 * H * np.sin(0.1 * k)])
        return base + c, np.zeros((4, 2))
    ang = 0.004 * k
    R = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    c = np.array([W / 2 + 0.1 * W * np.sin(0.05 * k), H / 2 + 0.08 * H * np.sin(0.037 * k)])
    if kind == "gradient":
        c[0] = W / 2 + 0.3 * W * np.sin(0.06 * k)
    return base @ R.T + c, np.zeros((4, 2))


def dot_sequence(
    kind: str,
    n_frames: int,
    *,
    size: tuple[int, int] = (160, 120),
    noise: float = 2.0,
    blur_px: float = 0.7,
    occlusion: int = 10,
    seed: int = 0,
) -> Iterator[DotSequenceFrame]:
    """Yield ``n_frames`` frames of sequence ``kind`` (module docstring) at ``size = (W, H)``.

    Args:
        kind: One of :data:`SEQUENCE_KINDS`.
        n_frames: Frames.
        size: Image width and height (pixels).
        noise: Standard deviation of the pixel noise (gray levels).
        blur_px: Standard deviation of the optics' Gaussian blur (pixels).
        occlusion: Frames dot 2 stays hidden (``"occlusion"``; from frame ``n_frames // 3``).
        seed: Seed of the noise.
    """
    if kind not in SEQUENCE_KINDS:
        raise ConfigurationError(f"sequence kind must be one of {SEQUENCE_KINDS}, got {kind!r}")
    cv2 = require_cv2()
    W, H = size
    scale = min(W, H) / 120.0
    spacing, r = 40.0 * scale, 3.5 * np.sqrt(scale)
    rng = np.random.default_rng(seed)
    light = np.ones((H, W), np.float32)
    if kind == "gradient":
        light = np.tile(np.linspace(1.0, 0.3, W, dtype=np.float32), (H, 1))
    for k in range(n_frames):
        uv, motion = _target(k, kind, W, H, spacing)
        visible = np.ones(4, bool)
        paper = 215.0 if kind == "nested" else 40.0
        img = np.full((H, W), paper, np.float32)
        if kind in ("bright_crossing", "bright_merge"):
            x0 = 0.3 * W + 0.4 * W * 30 / 60.0 - 0.5 * spacing
            x0 -= r  # the band is 2 r + 8 frames of motion wide
            xa, xb = int(x0), int(x0 + 8 * 0.4 * W / 60.0 + 2 * r)
            img[:, xa:xb] = 150.0 if kind == "bright_crossing" else 230.0
            if kind == "bright_merge":  # hidden while within 2 px of the band (blur joins them)
                visible = (uv[:, 0] + r + 2.0 <= xa) | (uv[:, 0] - r - 2.0 >= xb)
        if kind == "nested":
            for p in uv:
                _paint_square(img, float(p[0]), float(p[1]), 2.6 * r, 25.0)
        for i, p in enumerate(uv):
            _paint_disc(img, p, r, 225.0 if kind == "nested" else 230.0, tuple(motion[i]))
        if kind == "digits":
            ink = np.zeros((H, W), np.uint8)
            for i, p in enumerate(uv):
                org = (int(p[0] + 2 * r), int(p[1] + 3 * r))
                font = cv2.FONT_HERSHEY_SIMPLEX
                cv2.putText(ink, str(i + 1), org, font, 0.4 * scale, 255, 1, cv2.LINE_AA)
            a = ink.astype(np.float32) / 255.0
            img = img * (1.0 - a) + 230.0 * a
        if kind == "occlusion" and n_frames // 3 <= k < n_frames // 3 + occlusion:
            _paint_square(img, float(uv[2, 0]), float(uv[2, 1]), 2.0 * r, paper)
            visible[2] = False
        if blur_px > 0.0:
            img = cv2.GaussianBlur(img, (0, 0), blur_px)
        img *= light
        if noise > 0.0:
            img += rng.normal(0.0, noise, img.shape).astype(np.float32)
        out = np.clip(np.rint(img), 0, 255).astype(np.uint8)
        yield DotSequenceFrame(out, uv, visible)
