"""Motion blur: the image of an exposure during which the camera (or the scene) moved.

A pixel of a real sensor integrates the light it receives over the exposure. With each
object's footprint ``α_i(u, v, τ)`` (coverage in [0, 1], :class:`~redservo.vision.shapes.Layer`)
at the instants ``τ_1 … τ_N`` of the exposure window, the blurred footprint is their mean

    ``ᾱ_i(u, v) = (1/N) Σ_j α_i(u, v, τ_j)``

composited as one layer (far to near), then blurred optically, noised and quantized once
(:meth:`~redservo.vision.render.Renderer.render_layers`), as a single frame: the noise is
the frame's, not averaged down. Footprints are matched across instants by object and order.
Used by :class:`redservo.sensors.timing.TimedSensor` with an image sensor's ``read(..., image)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray, as_transform
from redservo.camera import MIN_DEPTH
from redservo.kernels._jit import COMPILED
from redservo.kernels.blob_expose import expose_dots
from redservo.kernels.dot_pixels import dot_pixels, dot_points
from redservo.scene import PointSet
from redservo.vision.lazyframe import FrameParts, LazyFrame, pixels
from redservo.vision.shapes import Layer, disc_coverage

if TYPE_CHECKING:  # pragma: no cover
    from redservo.scene import Scene
    from redservo.vision.render import Renderer

__all__ = ["exposed_frame", "exposed_image"]


def _mean_layer(group: list[Layer], n: int) -> Layer:
    """The footprint averaged over ``n`` instants (absent from some: zero coverage there)."""
    discs = [ly.disc for ly in group if ly.disc is not None]
    if len(discs) == len(group) and len({d[2] for d in discs}) == 1:  # a dot's discs
        cu, cv = (np.array([d[i] for d in discs]) for i in (0, 1))
        return _layer(group, _disc_mean(cu, cv, discs[0][2], n))

    def coverage(rows: slice, cols: slice) -> FloatArray:
        out = np.zeros((rows.stop - rows.start, cols.stop - cols.start))
        for ly in group:
            lr0, lr1 = max(ly.rect[0], rows.start), min(ly.rect[1], rows.stop)
            lc0, lc1 = max(ly.rect[2], cols.start), min(ly.rect[3], cols.stop)
            if lr0 < lr1 and lc0 < lc1:
                part = ly.coverage(slice(lr0, lr1), slice(lc0, lc1))
                out[lr0 - rows.start : lr1 - rows.start, lc0 - cols.start : lc1 - cols.start] += (
                    part
                )
        return out / n

    return _layer(group, coverage)


def _layer(group: list[Layer], coverage: Callable[[slice, slice], FloatArray]) -> Layer:
    """The layer of ``group``'s union rectangle and mean depth with ``coverage``."""
    rect = (
        min(ly.rect[0] for ly in group),
        max(ly.rect[1] for ly in group),
        min(ly.rect[2] for ly in group),
        max(ly.rect[3] for ly in group),
    )
    depth = float(np.mean([ly.depth for ly in group]))
    first = group[0]
    return Layer(first.name, first.kind, depth, first.level, rect, coverage)


def exposed_image(
    renderer: Renderer, scene: Scene, samples: Sequence[tuple[FloatArray, float]]
) -> NDArray[np.uint8]:
    """One frame (H, W) uint8 exposed over the camera poses and times ``samples``
    (``(bMc 4x4, t s)``, evenly spread over the exposure window; module docstring)."""
    return pixels(exposed_frame(renderer, scene, samples))


def exposed_frame(
    renderer: Renderer,
    scene: Scene,
    samples: Sequence[tuple[FloatArray, float]],
    stacked: FloatArray | None = None,
) -> LazyFrame | NDArray[np.uint8]:
    """:func:`exposed_image`, computed where it is read
    (:meth:`~redservo.vision.render.Renderer.lazy`). ``stacked``: the samples' poses
    (instants, 4, 4), proper transforms already (the camera's timing interpolates them
    between checked poses), or None: each pose is checked here."""
    frame = _dot_frame(renderer, scene, samples, stacked)
    if frame is not None:
        return frame
    layers = _dot_layers(renderer, scene, samples, stacked)
    if layers is None:
        groups: dict[tuple[str, str, int], list[Layer]] = {}
        for bMc, t in samples:
            seen: dict[tuple[str, str], int] = {}
            for ly in renderer.layers(scene, bMc, t):
                k = seen.get((ly.name, ly.kind), 0)
                seen[(ly.name, ly.kind)] = k + 1
                groups.setdefault((ly.name, ly.kind, k), []).append(ly)
        layers = [_mean_layer(group, len(samples)) for group in groups.values()]
    layers.sort(key=lambda ly: -ly.depth)
    return renderer.lazy(layers)


def _dot_geometry(
    renderer: Renderer,
    scene: Scene,
    samples: Sequence[tuple[FloatArray, float]],
    stacked: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_], list[str]] | None:
    """Every instant's dots of a scene of point sets only, projected at once: their camera
    points ``P`` (instants, dots, 3), pixels ``UV`` (instants, dots, 2), discs' rectangles
    ``lo``, ``hi`` (2, instants, dots: rows, then columns), whether each is drawn and the
    dots' names. None for any other scene or a renderer with its own
    :meth:`~redservo.vision.render.Renderer.layers`."""
    from redservo.vision.render import Renderer

    if type(renderer).layers is not Renderer.layers:
        return None
    sets = []
    for name in scene.names:
        obj = scene.object(name)
        if not isinstance(obj, PointSet):
            return None
        sets.append((name, obj))
    names = [f"{obj.name}[{k}]" for _, obj in sets for k in range(len(obj.points))]
    P = _dot_points(scene, sets, samples, len(names), stacked)
    return (P, *_dot_pixels(renderer, P), names)


def _dot_points(
    scene: Scene,
    sets: list[tuple[str, PointSet]],
    samples: Sequence[tuple[FloatArray, float]],
    n: int,
    stacked: FloatArray | None = None,
) -> FloatArray:
    """The ``n`` dots of the point sets ``sets`` in the camera frame (instants, dots, 3; m):
    :meth:`~redservo.scene.Scene.cMo`'s products, in one compiled call
    (:func:`redservo.kernels.dot_pixels.dot_points`, the same numbers) or here;
    ``stacked``: :func:`exposed_frame`'s."""
    if COMPILED and sets:
        if stacked is None:
            stacked = np.array([as_transform(T, "bMc") for T, _ in samples])
        bMc = stacked
        wMo = np.array([[scene._target_pose(name, t)[1] for name, _ in sets] for _, t in samples])
        base = scene._target_pose(sets[0][0], samples[0][1])[0]
        pts = np.concatenate([obj.points for _, obj in sets])
        starts = np.cumsum([0] + [len(obj.points) for _, obj in sets])
        bMw = base if base.shape[0] else np.eye(4)
        out: FloatArray = dot_points(bMc, wMo, bMw, bool(base.shape[0]), pts, starts)
        return out
    P = np.empty((len(samples), n, 3))
    for i, (bMc, t) in enumerate(samples):
        cMw = scene._cMw(bMc)  # once per instant: Scene.cMo's product, factor by factor
        at = 0
        for name, obj in sets:
            cMo = cMw @ scene._target_pose(name, t)[1]
            pts = obj.points
            P[i, at : at + len(pts)] = pts @ cMo[:3, :3].T + cMo[:3, 3]
            at += len(pts)
    return P


def _dot_pixels(
    renderer: Renderer, P: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """``(UV, lo, hi, seen)`` of :func:`_dot_geometry` from the camera points ``P``: in one
    compiled call through a camera without distortion
    (:func:`redservo.kernels.dot_pixels.dot_pixels`, the same numbers), else here."""
    optics, R = renderer.optics, renderer.options.levels.dot_radius_px
    h, w = optics.shape
    if COMPILED and not optics.distorted:
        c = optics.camera
        k = np.array([c.px, c.py, c.u0, c.v0, R, h, w, MIN_DEPTH], dtype=float)
        out: tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]] = dot_pixels(P, k)
        return out
    front = P[..., 2] > MIN_DEPTH
    UV = optics.to_pixel(P[..., :2] / np.where(front, P[..., 2], 1.0)[..., None])
    box = np.stack([UV[..., 1] - R - 2, UV[..., 1] + R + 2, UV[..., 0] - R - 2, UV[..., 0] + R + 2])
    with np.errstate(invalid="ignore"):
        lo = np.maximum(np.floor(box[0::2]), 0.0)
        hi = np.minimum(np.ceil(box[1::2]), [[[h]], [[w]]])
        seen = front & np.isfinite(UV).all(axis=-1) & (lo < hi).all(axis=0)
    return UV, lo, hi, seen


def _dot_frame(
    renderer: Renderer,
    scene: Scene,
    samples: Sequence[tuple[FloatArray, float]],
    stacked: FloatArray | None = None,
) -> LazyFrame | None:
    """The exposed frame of a scene of point sets in one compiled call
    (:func:`redservo.kernels.blob_expose.expose_dots`: the layers of :func:`_dot_layers`
    composited as :meth:`~redservo.vision.render.Renderer.lazy` does, bit for bit), the
    patches blurred here; None where that does not apply (no numba, another scene, a
    renderer with its own compositing)."""
    from redservo.vision.render import Renderer

    kind = type(renderer)
    if (
        not COMPILED
        or kind.lazy is not Renderer.lazy
        or kind.render_layers is not Renderer.render_layers
    ):
        return None
    geo = _dot_geometry(renderer, scene, samples, stacked)
    if geo is None:
        return None
    P, UV, lo, hi, seen, _ = geo
    opt = renderer.options
    bg, bg_blurred = renderer._background()
    field_, offset = renderer._noise_offset() if opt.noise_px > 0.0 else (bg_blurred, (0, 0))
    m = int(np.ceil(3.0 * opt.blur_px)) + 1 if opt.blur_px > 0.0 else 0
    k = np.array([opt.levels.dot_radius_px, opt.levels.point, len(samples), m], dtype=float)
    z = np.ascontiguousarray(P[..., 2])
    boxes, deltas = expose_dots(UV, z, seen, lo, hi, bg, k)
    packed = np.empty((len(boxes), 5), np.int64)  # FrameParts' boxes: rectangle, start
    blurred, start = np.empty_like(deltas), 0
    for g, (r0, r1, c0, c1) in enumerate(boxes.tolist()):
        n = (r1 - r0) * (c1 - c0)
        delta = deltas[start : start + n].reshape(r1 - r0, c1 - c0)
        blurred[start : start + n] = renderer._blur(delta).ravel()
        packed[g] = (r0, r1, c0, c1, start)
        start += n
    parts = FrameParts.packed(
        bg_blurred, field_, offset, opt.noise_px, packed, blurred, renderer.gain
    )
    return LazyFrame(parts)


def _dot_layers(
    renderer: Renderer,
    scene: Scene,
    samples: Sequence[tuple[FloatArray, float]],
    stacked: FloatArray | None = None,
) -> list[Layer] | None:
    """The mean layers of a scene of point sets only, every instant's dots projected at
    once: the layers of the general path (the same numbers, groups in the same order),
    without a layer object per dot and instant. None for any other scene or a renderer
    with its own :meth:`~redservo.vision.render.Renderer.layers`."""
    geo = _dot_geometry(renderer, scene, samples, stacked)
    if geo is None:
        return None
    P, UV, lo, hi, seen, names = geo
    lv = renderer.options.levels
    members: dict[int, list[int]] = {}  # dot -> its instants, in the general path's order
    for i in range(len(samples)):
        k = np.flatnonzero(seen[i])
        for j in k[np.argsort(-P[i, k, 2], kind="stable")]:
            members.setdefault(int(j), []).append(i)
    layers = []
    for j, inst in members.items():
        rect = (
            int(lo[0, inst, j].min()),
            int(hi[0, inst, j].max()),
            int(lo[1, inst, j].min()),
            int(hi[1, inst, j].max()),
        )
        depth = float(np.mean([P[i, j, 2] for i in inst]))
        cov = _disc_mean(UV[inst, j, 0], UV[inst, j, 1], lv.dot_radius_px, len(samples))
        layers.append(Layer(names[j], "point", depth, lv.point, rect, cov))
    return layers


def _disc_mean(
    cu: FloatArray, cv: FloatArray, radius: float, n: int
) -> Callable[[slice, slice], FloatArray]:
    """The coverage of a dot's discs summed in order over the instants, divided by ``n``."""

    def coverage(rows: slice, cols: slice) -> FloatArray:
        out = np.zeros((rows.stop - rows.start, cols.stop - cols.start))
        for part in disc_coverage(rows, cols, cu, cv, radius):
            out += part  # 0 outside the disc's own rectangle: the general path's sum
        return out / n

    return coverage
