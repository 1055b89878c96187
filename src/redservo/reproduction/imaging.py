"""Realistic imaging for the reproductions: what a real camera adds that the detector must live with.

:class:`Imaging` describes how the image differs from the controller's model of it:

* ``noise_px``: additive Gaussian pixel noise, standard deviation in gray levels (0-255);
* ``blur_px``: Gaussian blur, standard deviation in pixels;
* ``focal_scale``: the camera's true focal lengths are ``focal_scale`` times the ones the
  controller and the detector use (an uncalibrated focal length: 1.05 is +5 %);
* ``k1``, ``k2``, ``p1``, ``p2``: distortion of the true lens (OpenCV's model, normalized
  units; :class:`redservo.camera.Camera`), **left uncorrected**: the detector converts pixels
  with the controller's camera model, without it;
* ``gradient``: a lighting gradient, the image multiplied by a gain going linearly from
  ``1 − gradient`` at the left border to ``1 + gradient`` at the right one and by the same
  amount top to bottom (so ``0.15`` is ±15 % of light along each axis).

:func:`image_sensor` builds a :class:`redservo.vision.ImageSensor` (true depth, so that only
the measurement differs) whose renderer draws the scene with the *true* camera and lens and
applies the gradient, while the detector normalizes with the nominal camera: the image
errors reach the features exactly as they would on a real, imperfectly calibrated camera.
The detector is the library's, unchanged: it tracks each dot with its own gray levels
(:class:`~redservo.vision.tracking.ImageDotTracker`) and scales a sphere's threshold by the
light measured at it, so the gradient costs no feature.

:data:`REALISTIC` is what ``redservo reproduce --sensor image`` uses.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo.errors import ConfigurationError

if TYPE_CHECKING:
    from redservo.camera import Camera
    from redservo.vision import ImageSensor

__all__ = ["IDEAL_IMAGE", "REALISTIC", "Imaging", "image_sensor"]


@dataclass(frozen=True)
class Imaging:
    """How the rendered image differs from the controller's camera model (module docstring).

    Attributes:
        noise_px: Pixel noise, standard deviation (gray levels, >= 0).
        blur_px: Gaussian blur, standard deviation (pixels, >= 0).
        focal_scale: True focal length / assumed focal length (> 0; 1 = calibrated).
        k1: Uncorrected radial distortion of the true lens, r² term (dimensionless).
        k2: Uncorrected radial distortion, r⁴ term (dimensionless).
        p1: Uncorrected tangential distortion (dimensionless).
        p2: Uncorrected tangential distortion (dimensionless).
        gradient: Lighting gradient, relative gain change from the centre to a border (>= 0, < 1).
    """

    noise_px: float = 0.0
    blur_px: float = 0.0
    focal_scale: float = 1.0
    k1: float = 0.0
    gradient: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0

    def __post_init__(self) -> None:
        checks = {
            "noise_px": self.noise_px >= 0.0,
            "blur_px": self.blur_px >= 0.0,
            "focal_scale": self.focal_scale > 0.0,
            "k1": abs(self.k1) <= 1.0,
            "k2": abs(self.k2) <= 1.0,
            "p1": abs(self.p1) <= 1.0,
            "p2": abs(self.p2) <= 1.0,
            "gradient": 0.0 <= self.gradient < 1.0,
        }
        for name, ok in checks.items():
            value = getattr(self, name)
            if not (np.isfinite(value) and ok):
                raise ConfigurationError(
                    f"Imaging.{name} out of range: {value!r} (noise_px, blur_px >= 0; "
                    "focal_scale > 0; |k1|, |k2|, |p1|, |p2| <= 1; 0 <= gradient < 1)",
                    argument=name,
                )

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def describe(self) -> str:
        """One line for the report."""
        return (
            f"noise σ = {self.noise_px:g} gray levels, blur σ = {self.blur_px:g} px, "
            f"focal length {100.0 * (self.focal_scale - 1.0):+g} % uncalibrated, "
            f"uncorrected lens distortion k1 = {self.k1:g}, k2 = {self.k2:g}, p1 = {self.p1:g}, "
            f"p2 = {self.p2:g} (OpenCV's model), lighting gradient "
            f"±{100.0 * self.gradient:g} % per axis"
        )


REALISTIC = Imaging(noise_px=4.0, blur_px=0.8, focal_scale=1.0, k1=-0.05, gradient=0.15)
"""``reproduce --sensor image``: noise σ = 4 gray levels (in the 2-5 of a good industrial
camera), blur σ = 0.8 px, radial distortion k1 = −0.05 left uncorrected (about 0.8 px at 0.3
normalized units from the centre, 9 px in the image corners of the 640×480, f = 600 px camera),
a ±15 % lighting gradient per axis; calibrated focal length."""

IDEAL_IMAGE = Imaging()
"""A perfect image: only the rendering's pixel quantization."""


def image_sensor(camera: Camera, imaging: Imaging, *, seed: int = 0) -> ImageSensor:
    """An :class:`~redservo.vision.ImageSensor` for ``camera`` seeing through ``imaging``.

    The detector normalizes with ``camera`` as given; the image is drawn by ``camera`` with its
    focal lengths scaled by ``imaging.focal_scale`` and, when ``imaging`` has any distortion,
    the lens ``(k1, k2, p1, p2)`` of ``imaging`` (replacing the camera's), then lit with the
    gradient. True depth (:mod:`redservo.vision.depth`).
    """
    from redservo.vision import ImageSensor

    sensor = ImageSensor(
        camera, noise_px=imaging.noise_px, blur_px=imaging.blur_px, depth="true", seed=seed
    )
    sensor.renderer = _renderer(sensor.renderer.camera, sensor.renderer.options, imaging)
    return sensor


def _renderer(camera: Camera, options: Any, imaging: Imaging) -> Any:
    """A :class:`~redservo.vision.render.Renderer` drawing through the true camera and lens."""
    from redservo._validation import as_transform
    from redservo.vision.optics import Optics
    from redservo.vision.render import Renderer
    from redservo.vision.shapes import scene_layers

    class _TrueLensRenderer(Renderer):
        """Draws with the true optics (focal error, distortion) and lights with a gradient;
        ``self.optics`` stays the nominal model, which the detector uses."""

        def __init__(self) -> None:
            super().__init__(camera, options)
            s = imaging.focal_scale
            true_cam = replace(camera, px=camera.px * s, py=camera.py * s)
            lens = (imaging.k1, imaging.k2, imaging.p1, imaging.p2)
            if any(lens):
                true_cam = replace(true_cam, k1=lens[0], k2=lens[1], p1=lens[2], p2=lens[3], k3=0.0)
            self.true_optics = Optics(true_cam)
            if imaging.gradient != 0.0:  # the light's gain on the quantized image
                h, w = self.optics.shape
                gu = np.linspace(-imaging.gradient, imaging.gradient, w, dtype=np.float32)
                gv = np.linspace(-imaging.gradient, imaging.gradient, h, dtype=np.float32)
                self.gain = (1.0 + gv[:, None]) * (1.0 + gu[None, :])

        def layers(self, scene: Any, bMc: Any, t: float = 0.0) -> Any:
            return scene_layers(
                scene, as_transform(bMc, "bMc"), t, self.true_optics, self.options.levels
            )

    return _TrueLensRenderer()
