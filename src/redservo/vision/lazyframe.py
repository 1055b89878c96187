"""A rendered frame whose pixels are computed only where they are read.

A dot tracker reads a few windows around its dots' predicted positions, a fraction of a
640 x 480 frame. :meth:`redservo.vision.render.Renderer.frame` therefore returns a
:class:`LazyFrame`: everything that depends on the whole frame is done at once (the
noise offset drawn from the renderer's random stream, the objects' footprints composited
and blurred in their own patches), and the pixels of a region are computed when it is
first asked for (:meth:`LazyFrame.region`, compiled:
:func:`redservo.kernels.compose.compose_region`). Every pixel depends on the frame and its
own position only, so a region is bit for bit the crop of the whole frame
(:meth:`LazyFrame.full`, which is also what ``np.asarray(frame)`` gives), noise and blur
included; tests/test_lazyframe.py checks it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo.errors import ShapeError
from redservo.kernels.compose import compose_region

__all__ = ["FrameParts", "LazyFrame", "frame_or_array", "pixels", "window"]

_NO_GAIN = np.ones((1, 1), np.float32)


class FrameParts:
    """What one frame is made of (arguments of :func:`compose_region` but the region).

    Args:
        bgb: (H, W) float32 blurred background.
        field: (2H, 2W) float32 noise field (any when ``sigma`` is 0).
        offset: ``(r, c)`` the frame's offset into ``field`` (pixels).
        sigma: Noise standard deviation (gray levels).
        patches: ``((r0, r1, c0, c1), Δ)`` the blurred footprints (float32), disjoint.
        gain: (H, W) float32 light gain, or None.
    """

    def __init__(
        self,
        bgb: NDArray[np.float32],
        field: NDArray[np.float32],
        offset: tuple[int, int],
        sigma: float,
        patches: list[tuple[tuple[int, int, int, int], NDArray[np.float32]]],
        gain: NDArray[np.float32] | None = None,
        _packed: tuple[NDArray[np.int64], NDArray[np.float32]] | None = None,
    ) -> None:
        self.bgb, self.field, self.gain = bgb, field, gain
        self.offset = np.array(offset, dtype=np.int64)
        self.sigma = float(np.float32(sigma))  # OpenCV's scaleAdd takes it as a float32
        if _packed is not None:  # :meth:`packed`
            self.boxes, self.deltas = _packed
            return
        starts = np.cumsum([0] + [d.size for _, d in patches])
        self.boxes = np.array(
            [(*rect, s) for (rect, _), s in zip(patches, starts)], dtype=np.int64
        ).reshape(-1, 5)
        self.deltas = (
            np.concatenate([d.ravel() for _, d in patches]).astype(np.float32, copy=False)
            if patches
            else np.zeros(0, np.float32)
        )

    @classmethod
    def packed(
        cls,
        bgb: NDArray[np.float32],
        field: NDArray[np.float32],
        offset: tuple[int, int],
        sigma: float,
        boxes: NDArray[np.int64],
        deltas: NDArray[np.float32],
        gain: NDArray[np.float32] | None = None,
    ) -> FrameParts:
        """The parts of the patches given as :attr:`boxes` ((P, 5) int64: ``r0, r1, c0,
        c1`` and each patch's start in ``deltas``) and :attr:`deltas` (float32, the
        patches row-major, concatenated): the constructor's parts of the same patches
        given one by one, without packing them again."""
        return cls(bgb, field, offset, sigma, [], gain, (boxes, deltas))


class LazyFrame:
    """An (H, W) uint8 frame computed region by region (module docstring)."""

    ndim = 2
    dtype = np.dtype(np.uint8)

    def __init__(self, parts: FrameParts) -> None:
        self.parts = parts
        self.shape: tuple[int, int] = (int(parts.bgb.shape[0]), int(parts.bgb.shape[1]))
        self.pixels = np.empty(self.shape, np.uint8)
        """The frame's buffer: valid in the regions computed so far."""
        self._done: list[tuple[int, int, int, int]] = []

    def region(self, r0: int, r1: int, c0: int, c1: int) -> NDArray[np.uint8]:
        """The pixels of rows ``[r0, r1)``, columns ``[c0, c1)`` (clipped to the frame), a
        view of :attr:`pixels`, computed if not yet."""
        h, w = self.shape
        r0, r1, c0, c1 = max(int(r0), 0), min(int(r1), h), max(int(c0), 0), min(int(c1), w)
        if (
            r0 < r1
            and c0 < c1
            and not any(a <= r0 and r1 <= b and c <= c0 and c1 <= d for a, b, c, d in self._done)
        ):
            p = self.parts
            gain = _NO_GAIN if p.gain is None else p.gain
            rect = np.array([r0, r1, c0, c1], dtype=np.int64)
            self.pixels[r0:r1, c0:c1] = compose_region(
                rect, p.bgb, p.field, p.offset, p.sigma, p.boxes, p.deltas, gain, p.gain is not None
            )
            self._done.append((r0, r1, c0, c1))
        return self.pixels[r0:r1, c0:c1]

    def full(self) -> NDArray[np.uint8]:
        """The whole frame (H, W) uint8."""
        return self.region(0, self.shape[0], 0, self.shape[1])

    def __array__(self, dtype: Any = None, copy: Any = None) -> NDArray[Any]:
        full = self.full()
        return full if dtype is None else full.astype(dtype)

    def __getitem__(self, key: Any) -> Any:
        return self.full()[key]


def pixels(image: Any) -> NDArray[np.uint8]:
    """``image`` as a whole (H, W) array (a :class:`LazyFrame` is computed in full)."""
    return image.full() if isinstance(image, LazyFrame) else np.asarray(image)


def window(image: Any, r0: int, r1: int, c0: int, c1: int) -> NDArray[np.uint8]:
    """Rows ``[r0, r1)``, columns ``[c0, c1)`` (>= 0) of ``image``, an array or a
    :class:`LazyFrame` (computed there if not yet)."""
    if isinstance(image, LazyFrame):
        return image.region(r0, r1, c0, c1)
    out: NDArray[np.uint8] = image[r0:r1, c0:c1]
    return out


def frame_or_array(image: Any) -> Any:
    """``image`` as a 2-D uint8 array, or the :class:`LazyFrame` itself (read by windows).

    Raises:
        ShapeError: ``image`` is neither.
    """
    if isinstance(image, LazyFrame):
        return image
    img = np.asarray(image)
    if img.ndim != 2 or img.dtype != np.uint8:
        raise ShapeError(f"image must be a 2-D uint8 array, got {img.dtype} of shape {img.shape}")
    return img
