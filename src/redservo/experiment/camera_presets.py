"""Shipped camera presets: one option to run any scenario or campaign through a camera.

``--camera NAME`` (``redservo run``, ``compare``, ``campaign``; ``reproduce --camera realistic`` runs the
reproduction's realistic image sensor through :data:`REALISTIC_TIMING`) applies the preset's
scenario overrides before the user's own ``--set`` (which therefore win):

* ``ideal``: nothing (the scenario's own sensor: exact features at every period);
* ``realistic``: the features detected in a rendered image (``sensor.kind = "image"``,
  the reproduction's realistic noise σ = 4 gray levels and optical blur σ = 0.8 px,
  :data:`redservo.reproduction.imaging.REALISTIC`) from a 30 Hz camera with 66 ms latency
  and an 8 ms exposure (motion blur), latency compensated (:mod:`redservo.sensors.timing`,
  :mod:`redservo.control.latency`), and convergence judged in pixels:
  ``simulation.tolerance_px`` = :data:`REALISTIC_TOLERANCE_PX` (docs/camera-timing.md),
  and the camera-motion limit ``sensor.motion_limit`` = :data:`REALISTIC_MOTION_LIMIT`;
  the depths of the interaction matrices from the dots' PnP pose (``sensor.depth = "pose"``,
  :mod:`redservo.vision.pnp`): through the desired depths instead, the laws' ``L`` differed
  from the ideal sensor's (true current depths, the scenarios' ``task.depth = "current"``)
  and the reactive laws stalled where they converge ideally (mc05-joint-limits, seed 0,
  sample 0: ``qp`` at ‖e1‖ = 0.087 after 600 iterations; converged in 285 with the pose);
  and a target whose dot touches the image border has left the image
  (``simulation.image_margin_px`` = :data:`REALISTIC_IMAGE_MARGIN_PX`): the run ends
  ``target_lost``, as on the ideal sensor, not ``feature_lost`` when the tracker then refuses
  the cut dot (``at_border``) for four frames.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from redservo.sensors.timing import CameraTiming

__all__ = [
    "CAMERA_PRESETS",
    "REALISTIC_IMAGE_MARGIN_PX",
    "REALISTIC_MOTION_LIMIT",
    "REALISTIC_TIMING",
    "REALISTIC_TOLERANCE_PX",
    "add_camera_option",
    "camera_overrides",
]

REALISTIC_TIMING = CameraTiming(rate=30.0, latency=0.066, exposure=0.008)
"""The ``realistic`` preset's camera: 30 Hz, 66 ms latency, 8 ms exposure."""

REALISTIC_MOTION_LIMIT = 0.5
"""The ``realistic`` preset's camera-motion limit: an image point moves at most half the dot
tracker's gate per frame (:class:`redservo.control.ImageMotionLimit`)."""

REALISTIC_TOLERANCE_PX = 1.0
"""Convergence threshold (px) of the ``realistic`` preset on ``‖e1‖·f``: 13 times the p99
(0.075 px) of the stacked error's noise at rest with the preset's image noise, measured on
panda-4points (docs/camera-timing.md)."""

REALISTIC_IMAGE_MARGIN_PX = 4.0
"""The ``realistic`` preset's ``simulation.image_margin_px`` (px): the default radius of a
rendered dot (``sensor.dot_radius_px`` = 4 px). A point closer to the border has its dot cut
by the border, which the dot tracker refuses (``at_border``; measured: lost at 4.0 px, found
at 4.1 px): through the camera the target has left the image (``target_lost``), as the
ideal sensor says when the point itself leaves it (margin 0). Without it, panda-near-limits
(seed 0) samples 11 (``qp``) and 71 (``predictive``) ended ``feature_lost`` with a dot
drifting out of the image, the tracker exact until then. A margin of 6.4 px (the radius and 3σ of the blur) ended two
runs that converge (samples 88 and 129) where a dot passed 4-6 px from the border."""

CAMERA_PRESETS: dict[str, tuple[str, ...]] = {
    "ideal": (),
    "realistic": (
        'sensor.kind="image"',
        "sensor.noise_px=4.0",
        "sensor.blur_px=0.8",
        f"sensor.rate={REALISTIC_TIMING.rate!r}",
        f"sensor.latency={REALISTIC_TIMING.latency!r}",
        f"sensor.exposure={REALISTIC_TIMING.exposure!r}",
        f"simulation.tolerance_px={REALISTIC_TOLERANCE_PX!r}",
        f"sensor.motion_limit={REALISTIC_MOTION_LIMIT!r}",
        'sensor.depth="pose"',
        f"simulation.image_margin_px={REALISTIC_IMAGE_MARGIN_PX!r}",
    ),
}
"""Each preset's ``--set`` overrides, in order."""


def camera_overrides(name: str) -> list[str]:
    """The overrides of preset ``name`` (a key of :data:`CAMERA_PRESETS`)."""
    return list(CAMERA_PRESETS[name])


class _CameraAction(argparse.Action):
    """``--camera NAME``: the preset's overrides go before every ``--set`` of the command."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        setattr(namespace, self.dest, values)
        namespace.set = camera_overrides(str(values)) + list(getattr(namespace, "set", None) or [])


def add_camera_option(p: argparse.ArgumentParser, *, reproduce: bool = False) -> None:
    """Add ``--camera {ideal,realistic}`` to a command that has ``--set``, or (``reproduce``)
    to ``redservo reproduce``, whose runs through images it times."""
    if reproduce:
        p.add_argument(
            "--camera",
            choices=tuple(CAMERA_PRESETS),
            default="ideal",
            help="realistic: the runs through images (implies --sensor image) come from a 30 Hz "
            "camera, 66 ms latency (compensated), 8 ms exposure (docs/camera-timing.md)",
        )
        return
    p.add_argument(
        "--camera",
        choices=tuple(CAMERA_PRESETS),
        action=_CameraAction,
        default="ideal",
        help="camera preset: realistic = features in a rendered image from a 30 Hz camera, "
        "66 ms latency (compensated), 8 ms exposure, convergence within "
        f"{REALISTIC_TOLERANCE_PX:g} px (docs/camera-timing.md); before any --set",
    )
