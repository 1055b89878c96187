"""Compiled last stage of the renderer: one region of a frame, noised, composited, quantized.

:class:`redservo.vision.lazyframe.LazyFrame` computes the pixels of a rendered frame only
where they are read, with this kernel; the whole frame is the same kernel on the whole
image, so a region is bit for bit the crop of the full frame. Per pixel ``(i, j)``, in
this order (:mod:`redservo.vision.render` gives the pipeline):

1. the blurred background ``B[i, j]`` (float32);
2. plus the noise ``σ N[r + i, c + j]`` (``N`` the renderer's unit-variance noise field,
   ``(r, c)`` the frame's offset into it: each pixel's noise depends on the frame and the
   pixel only), rounded once to float32 (a fused multiply-add: the product of two float32
   numbers is exact in float64);
3. plus the blurred footprint of the objects ``Δ[i, j]`` where a patch covers the pixel
   (float32; the patches do not overlap);
4. rounded half to even and saturated to 0-255 (OpenCV's conversion to 8 bits);
5. optionally times a per-pixel light gain (float32), rounded and saturated again.

Array expressions only, so that the plain-numpy reference path is fast too.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["compose_region"]


@kernel
def compose_region(
    rect: Any,
    bgb: Any,
    field: Any,
    offset: Any,
    sigma: float,
    boxes: Any,
    deltas: Any,
    gain: Any,
    has_gain: bool,
) -> Any:
    """The uint8 pixels (r1 - r0, c1 - c0) of the region ``rect = (r0, r1, c0, c1)``.

    Args:
        rect: (4,) int64 region, half-open rows then columns (pixels).
        bgb: (H, W) float32 blurred background (gray levels).
        field: (2H, 2W) float32 unit-variance noise field.
        offset: (2,) int64 the frame's ``(r, c)`` offset into ``field``.
        sigma: Noise standard deviation (gray levels, float32-representable); 0 = none.
        boxes: (P, 5) int64 each patch's ``r0, r1, c0, c1`` and start in ``deltas``.
        deltas: (n,) float32 the patches' blurred footprints, row-major, concatenated.
        gain: (H, W) float32 light gain (any shape when ``has_gain`` is False).
        has_gain: Apply ``gain``.
    """
    r0, r1, c0, c1 = rect[0], rect[1], rect[2], rect[3]
    v = bgb[r0:r1, c0:c1].copy()
    if sigma > 0.0:
        nz = field[offset[0] + r0 : offset[0] + r1, offset[1] + c0 : offset[1] + c1]
        v = (nz.astype(np.float64) * sigma + v.astype(np.float64)).astype(np.float32)
    for k in range(boxes.shape[0]):
        b0, b1, b2, b3, start = boxes[k, 0], boxes[k, 1], boxes[k, 2], boxes[k, 3], boxes[k, 4]
        i0, i1, j0, j1 = max(b0, r0), min(b1, r1), max(b2, c0), min(b3, c1)
        if i0 < i1 and j0 < j1:
            patch = deltas[start : start + (b1 - b0) * (b3 - b2)].reshape((b1 - b0, b3 - b2))
            v[i0 - r0 : i1 - r0, j0 - c0 : j1 - c0] += patch[i0 - b0 : i1 - b0, j0 - b2 : j1 - b2]
    out = np.minimum(np.maximum(np.rint(v), np.float32(0.0)), np.float32(255.0))
    if has_gain:
        lit = out * gain[r0:r1, c0:c1]
        out = np.minimum(np.maximum(np.rint(lit), np.float32(0.0)), np.float32(255.0))
    return out.astype(np.uint8)
