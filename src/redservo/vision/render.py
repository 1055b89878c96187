"""Render the 8-bit grayscale image a pinhole camera sees (numpy + OpenCV blur).

:class:`Renderer` draws every object of a :class:`~redservo.scene.Scene` as
seen from the camera pose ``bMc`` at time ``t`` (geometry in
:mod:`redservo.vision.shapes`): the points of point sets as small discs, spheres
(the MC05 occluder included) as their filled ellipses, cylinders as the band
between their limbs, lines as thin stripes, all anti-aliased and composited
far to near over a uniform or textured background. Then, in this order:

1. Gaussian blur of standard deviation ``blur_px`` pixels (the optics' point
   spread), applied exactly: the blurred background is cached and only the
   objects' footprints (plus 3σ) are blurred each frame, which is the same
   image as blurring the whole frame because blurring is linear;
2. additive Gaussian noise of standard deviation ``noise_px`` gray levels per
   pixel (the sensor noise; ``noise_px`` = 1 is one gray level out of 255),
   i.i.d. over the pixels of a frame: each frame takes a randomly placed window
   of a noise field twice the image size, drawn once per seed (drawing 300 000
   normals costs more than the whole 2 ms frame budget);
3. rounding and clipping to ``uint8``.

Objects wholly outside the image or behind the camera draw nothing; partly
visible ones are clipped (a sphere straddling the camera plane is drawn as the
unbounded region it really images to). Lens distortion bends everything through
:class:`~redservo.vision.optics.Optics`: the camera's own (OpenCV's ``k1, k2, p1, p2, k3``)
or else these options' radial ``k1``, ``k2``. It is exact, not a remap of a pinhole image:
each pixel is shaded at the undistorted normalized point its centre images.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray, as_transform
from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.scene import Scene
from redservo.vision.lazyframe import FrameParts, LazyFrame, pixels
from redservo.vision.optics import Optics, require_cv2
from redservo.vision.shapes import Layer, Levels, Rect, scene_layers

__all__ = ["RenderOptions", "Renderer", "render"]

_TEXTURE_CELL_PX = 24
"""Correlation length of the background texture (pixels)."""


@dataclass(frozen=True)
class RenderOptions:
    """How the image is made (see the module docstring for the pipeline).

    Attributes:
        noise_px: Standard deviation of the additive Gaussian pixel noise, in gray
            levels (0-255) per pixel; 0 = none.
        blur_px: Standard deviation of the Gaussian blur, pixels; 0 = none.
        k1: Radial distortion coefficient of r² (normalized units, OpenCV's k1).
        k2: Radial distortion coefficient of r⁴.
        texture: Draw a smooth random background texture (amplitude
            ``texture_amplitude``, correlation length about 24 px) instead of a
            uniform background.
        seed: Seed of the noise and texture (None = fresh entropy).
        background: Background gray level.
        texture_amplitude: Standard deviation of the texture, gray levels.
        levels: Gray levels and sizes of the objects (:class:`~redservo.vision.shapes.Levels`).
    """

    noise_px: float = 0.0
    blur_px: float = 0.0
    k1: float = 0.0
    k2: float = 0.0
    texture: bool = False
    seed: int | None = 0
    background: float = 40.0
    texture_amplitude: float = 12.0
    levels: Levels = field(default_factory=Levels)

    def __post_init__(self) -> None:
        for name in ("noise_px", "blur_px", "texture_amplitude"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise ConfigurationError(
                    f"RenderOptions.{name} must be finite and >= 0, got {value!r}"
                )
        if not 0.0 <= self.background <= 255.0:
            raise ConfigurationError(
                f"RenderOptions.background must be a gray level in [0, 255], got {self.background!r}"
            )
        lv = self.levels
        for name in ("point", "sphere", "cylinder", "line"):
            value = getattr(lv, name)
            if not 0.0 <= value <= 255.0:
                raise ConfigurationError(f"Levels.{name} must be in [0, 255], got {value!r}")
        for name in ("dot_radius_px", "line_width_px"):
            value = getattr(lv, name)
            if not (np.isfinite(value) and value > 0.0):
                raise ConfigurationError(f"Levels.{name} must be positive, got {value!r}")


_FIELDS: dict[tuple[int, int, int], tuple[NDArray[np.float32], dict[str, Any]]] = {}
"""The noise field of each ``(seed, height, width)`` drawn lately (at most 4, read-only) and
the random stream's state right after its draw: each run's renderer restarts at its seed."""


def _merge(rects: list[Rect]) -> list[tuple[Rect, list[int]]]:
    """Merge overlapping rectangles; return each merged rectangle with its members."""
    groups: list[tuple[Rect, list[int]]] = [(r, [i]) for i, r in enumerate(rects)]
    merged = True
    while merged:
        merged = False
        out: list[tuple[Rect, list[int]]] = []
        for rect, members in groups:
            for k, (other, others) in enumerate(out):
                if (
                    rect[0] < other[1]
                    and other[0] < rect[1]
                    and rect[2] < other[3]
                    and other[2] < rect[3]
                ):
                    union = (
                        min(rect[0], other[0]),
                        max(rect[1], other[1]),
                        min(rect[2], other[2]),
                        max(rect[3], other[3]),
                    )
                    out[k] = (union, others + members)
                    merged = True
                    break
            else:
                out.append((rect, members))
        groups = out
    return groups


class Renderer:
    """Stateful renderer: caches the background and the noise field, owns the random stream.

    Args:
        camera: Intrinsics and image size.
        options: :class:`RenderOptions`.
    """

    def __init__(self, camera: Camera | None = None, options: RenderOptions | None = None) -> None:
        self.options = options or RenderOptions()
        self.optics = Optics(camera or Camera(), self.options.k1, self.options.k2)
        self._cache: dict[str, Any] = {}
        self.gain: NDArray[np.float32] | None = None
        """(H, W) float32 light gain applied to the quantized image (None: none)."""
        self.reset()

    def reset(self) -> None:
        """Restart the random stream (same ``seed`` → same images)."""
        self._rng = np.random.default_rng(self.options.seed)
        self._cache.pop("noise", None)

    @property
    def camera(self) -> Camera:
        """The camera intrinsics."""
        return self.optics.camera

    def _background(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """(unblurred, blurred) background, float32 (H, W)."""
        if "bg" not in self._cache:
            opt = self.options
            h, w = self.optics.shape
            bg = np.full((h, w), opt.background, dtype=np.float32)
            if opt.texture and opt.texture_amplitude > 0.0:
                cv2 = require_cv2()
                trng = np.random.default_rng(None if opt.seed is None else opt.seed + 7919)
                coarse = trng.standard_normal(
                    (h // _TEXTURE_CELL_PX + 2, w // _TEXTURE_CELL_PX + 2)
                ).astype(np.float32)
                fine = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC)
                fine *= opt.texture_amplitude / max(float(fine.std()), 1e-6)
                bg += fine
            self._cache["bg"] = (bg, self._blur(bg))
        out: tuple[NDArray[np.float32], NDArray[np.float32]] = self._cache["bg"]
        return out

    def _blur(self, img: NDArray[np.float32]) -> NDArray[np.float32]:
        s = self.options.blur_px
        if s <= 0.0:
            return img.copy()
        cv2 = require_cv2()
        out: NDArray[np.float32] = cv2.GaussianBlur(img, (0, 0), sigmaX=s, sigmaY=s)
        return out

    def _noise_offset(self) -> tuple[NDArray[np.float32], tuple[int, int]]:
        """The per-seed noise field (2H, 2W, unit variance) and this frame's random offset
        ``(r, c)`` into it: the frame's noise is the (H, W) window at that offset, so each
        pixel's noise depends on the frame and its position only."""
        h, w = self.optics.shape
        if "noise" not in self._cache:
            # a seeded field is always the same: drawn once
            memo = None if self.options.seed is None else _FIELDS.get((self.options.seed, h, w))
            if memo is not None:
                self._cache["noise"] = memo[0]
                self._rng.bit_generator.state = dict(memo[1])  # the stream as if drawn again
            else:
                field_ = self._rng.standard_normal((2 * h, 2 * w), dtype=np.float32)
                field_.flags.writeable = False
                self._cache["noise"] = field_
                if self.options.seed is not None:
                    if len(_FIELDS) >= 4:
                        del _FIELDS[next(iter(_FIELDS))]
                    state = dict(self._rng.bit_generator.state)
                    _FIELDS[(self.options.seed, h, w)] = (field_, state)
        r, c = self._rng.integers(0, h), self._rng.integers(0, w)
        return self._cache["noise"], (int(r), int(c))

    def _noise(self) -> NDArray[np.float32]:
        """A random (H, W) window of the per-seed noise field (unit variance)."""
        h, w = self.optics.shape
        field_, (r, c) = self._noise_offset()
        return field_[r : r + h, c : c + w]

    def layers(self, scene: Scene, bMc: FloatArray, t: float = 0.0) -> list[Layer]:
        """The objects' footprints at this instant, far to near."""
        return scene_layers(scene, as_transform(bMc, "bMc"), t, self.optics, self.options.levels)

    def render(self, scene: Scene, bMc: FloatArray, t: float = 0.0) -> NDArray[np.uint8]:
        """Return the (height, width) uint8 image seen from camera pose ``bMc`` (4x4) at ``t`` (s)."""
        return self.render_layers(self.layers(scene, bMc, t))

    def render_layers(self, layers: list[Layer]) -> NDArray[np.uint8]:
        """Composite ``layers`` (far to near), blur, add noise, quantize: the whole frame."""
        return pixels(self.lazy(layers))

    def lazy_frame(
        self, scene: Scene, bMc: FloatArray, t: float = 0.0
    ) -> LazyFrame | NDArray[np.uint8]:
        """The frame of :meth:`render`, its pixels computed where they are read
        (:class:`~redservo.vision.lazyframe.LazyFrame`); a subclass that renders otherwise
        (its own :meth:`render` or :meth:`render_layers`) gives its whole image."""
        if type(self).render is not Renderer.render:
            return self.render(scene, bMc, t)
        return self.lazy(self.layers(scene, bMc, t))

    def lazy(self, layers: list[Layer]) -> LazyFrame | NDArray[np.uint8]:
        """The frame of ``layers`` (far to near), computed where it is read; the whole
        image when a subclass has its own :meth:`render_layers`."""
        if type(self).render_layers is not Renderer.render_layers:
            return self.render_layers(layers)
        opt = self.options
        bg, bg_blurred = self._background()
        field_, offset = self._noise_offset() if opt.noise_px > 0.0 else (bg_blurred, (0, 0))
        h, w = bg.shape
        m = int(np.ceil(3.0 * opt.blur_px)) + 1 if opt.blur_px > 0.0 else 0
        rects = [
            (max(r0 - m, 0), min(r1 + m, h), max(c0 - m, 0), min(c1 + m, w))
            for r0, r1, c0, c1 in (ly.rect for ly in layers)
        ]
        patches = []
        for (r0, r1, c0, c1), members in _merge(rects):
            patch = bg[r0:r1, c0:c1].copy()
            for i in sorted(members):  # layers are sorted far to near
                ly = layers[i]
                lr0, lr1, lc0, lc1 = ly.rect
                alpha = ly.coverage(slice(lr0, lr1), slice(lc0, lc1)).astype(np.float32)
                sub = patch[lr0 - r0 : lr1 - r0, lc0 - c0 : lc1 - c0]
                sub += alpha * (np.float32(ly.level) - sub)
            patches.append(((r0, r1, c0, c1), self._blur(patch - bg[r0:r1, c0:c1])))
        parts = FrameParts(bg_blurred, field_, offset, opt.noise_px, patches, self.gain)
        return LazyFrame(parts)


def render(
    scene: Scene,
    bMc: FloatArray,
    t: float = 0.0,
    *,
    camera: Camera | None = None,
    options: RenderOptions | None = None,
) -> NDArray[np.uint8]:
    """One image (H, W) uint8 of ``scene`` from camera pose ``bMc`` (4x4) at ``t`` (s).

    Convenience for a single frame; use a :class:`Renderer` for a sequence (it
    caches the background and draws fresh noise for every frame).
    """
    return Renderer(camera, options).render(scene, bMc, t)
