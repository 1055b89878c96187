"""Motion blur: the image of an exposure during which the camera (or the scene) moved.

A pixel of a real sensor integrates the light it receives over the exposure. With each
object's footprint ``α_i(u, v, τ)`` (coverage in [0, 1], :class:`~redservo.vision.shapes.Layer`)
at the instants ``τ_1 … τ_N`` of the exposure window, the blurred footprint is their mean

    ``ᾱ_i(u, v) = (1/N) Σ_j α_i(u, v, τ_j)``

composited as one layer (far to near), then blurred optically, noised and quantized once
(:meth:`~redservo.vision.render.Renderer.render_layers`), as a single frame: the noise is
the frame's, not averaged down. Footprints are matched across instants by object and order.
Used by :class:`redservo.sensor_timing.TimedSensor` with an image sensor's ``read(..., image)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.vision.shapes import Layer

if TYPE_CHECKING:  # pragma: no cover
    from redservo.scene import Scene
    from redservo.vision.render import Renderer

__all__ = ["exposed_image"]


def _mean_layer(group: list[Layer], n: int) -> Layer:
    """The footprint averaged over ``n`` instants (absent from some: zero coverage there)."""
    r0 = min(ly.rect[0] for ly in group)
    r1 = max(ly.rect[1] for ly in group)
    c0 = min(ly.rect[2] for ly in group)
    c1 = max(ly.rect[3] for ly in group)

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

    depth = float(np.mean([ly.depth for ly in group]))
    first = group[0]
    return Layer(first.name, first.kind, depth, first.level, (r0, r1, c0, c1), coverage)


def exposed_image(
    renderer: Renderer, scene: Scene, samples: Sequence[tuple[FloatArray, float]]
) -> NDArray[np.uint8]:
    """One frame (H, W) uint8 exposed over the camera poses and times ``samples``
    (``(bMc 4x4, t s)``, evenly spread over the exposure window; module docstring)."""
    groups: dict[tuple[str, str, int], list[Layer]] = {}
    for bMc, t in samples:
        seen: dict[tuple[str, str], int] = {}
        for ly in renderer.layers(scene, bMc, t):
            k = seen.get((ly.name, ly.kind), 0)
            seen[(ly.name, ly.kind)] = k + 1
            groups.setdefault((ly.name, ly.kind, k), []).append(ly)
    layers = [_mean_layer(group, len(samples)) for group in groups.values()]
    layers.sort(key=lambda ly: -ly.depth)
    return renderer.render_layers(layers)
