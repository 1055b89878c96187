"""The image sensor: render the camera image, detect the task's features in it.

:class:`ImageSensor` implements :class:`redservo.sensors.Sensor`. Each
``read(task, scene, bMc, t)`` renders the image (:class:`~redservo.vision.render.Renderer`),
detects every task term in it in the features' own conventions and order, and
attaches the inverse-depth parameters of the ``depth`` policy (:mod:`redservo.vision.depth`).
Each term is planned and measured by its feature kind's adapters (``image_term``,
``measure_image``, :mod:`redservo.features.kinds`; the shipped ones in
:mod:`redservo.vision.measure`); a kind without them is refused. The shipped kinds:

* ``PointFeature``, ``MomentFeatures``: the dots of the term's point set (all
  sets tracked in the image by one :class:`~redservo.vision.tracking.ImageDotTracker`,
  each dot with its own gray levels: a lighting gradient does not lose it); a point
  term is the dot of its point, the moments come from all dots of the set;
* ``SphereFeature``: its ellipse, ``(xc, yc, a)`` or ``(xc, yc, n20, n11, n02)``;
* ``CylinderFeature``: both limbs (edges); ``LineFeature``: the stripe's centre line;
* a tag's corners and pose features: :mod:`redservo.vision.tag_sensor`.

Initialisation (decision): on the first frame after :meth:`reset`, trackers
start from the true projections (as a user clicking on the dots would); from
then on only the image is used. The dots' gray levels are learnt from the image; the
other detectors' thresholds come from the renderer's gray levels.

Losses: a term not detected in a frame is listed in ``SensorReading.lost`` (task
term indices) and keeps its last value (a dot coasts on its prediction), and ``reason``
names each lost dot with why (:data:`~redservo.vision.tracking.LOSS_REASONS`); a
whole-image blob count different from the number of dots is said in ``reason`` too. A
term lost for more than ``max_lost_frames`` consecutive frames (or never seen)
makes ``s`` None with a ``reason`` starting with ``"feature_lost:"``
(:data:`FEATURE_LOST`), the cue for the simulator to stop with outcome
``feature_lost``; :attr:`ImageSensor.feature_lost` says the same.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.camera import MIN_DEPTH, Camera
from redservo.errors import ConfigurationError, GeometryError
from redservo.features.kinds import feature_adapter
from redservo.sensors import SensorReading
from redservo.vision.depth import DEPTH_POLICIES, DepthPolicy
from redservo.vision.dots import DotTracker
from redservo.vision.ellipse import EllipseMethod
from redservo.vision.lazyframe import pixels
from redservo.vision.motion import camera_shift, normalized_dots
from redservo.vision.pnp import PoseMisses
from redservo.vision.render import Renderer, RenderOptions
from redservo.vision.tag_sensor import TagTerm, measure_tag, tag_term
from redservo.vision.terms import (
    TermState,
    dot_gate_px,
    dot_tracker,
    term_inv_depths,
    track_dots,
)
from redservo.vision.tracking import ImageDotTracker

if TYPE_CHECKING:  # pragma: no cover
    from redservo.scene import Scene
    from redservo.task import VisualTask

__all__ = ["FEATURE_LOST", "ImageSensor", "tracking_gate_px"]

FEATURE_LOST = "feature_lost"
"""Prefix of ``SensorReading.reason`` when a feature is lost for good."""

_CONFIG_KEYS: tuple[str, ...] = ("noise_px", "blur_px", "distortion", "texture", "seed")
_CONFIG_KEYS += ("depth", "max_lost_frames", "ellipse_method", "dot_radius_px")


class ImageSensor:
    """Features measured in a rendered image (module docstring).

    Args:
        camera: Intrinsics and image size (default :class:`~redservo.camera.Camera`).
        noise_px: Gaussian pixel noise, standard deviation in gray levels.
        blur_px: Gaussian blur, standard deviation in pixels.
        distortion: Radial distortion ``k1`` or ``(k1, k2)``.
        texture: Textured background.
        seed: Seed of the image noise and texture.
        depth: ``"desired"``, ``"estimated"`` or ``"true"`` (:mod:`redservo.vision.depth`).
        max_lost_frames: A term lost for more than this many consecutive frames is lost for good.
        ellipse_method: ``"moments"`` or ``"contour"`` (:mod:`redservo.vision.ellipse`).
        dot_radius_px: Radius of the rendered dots (pixels).
        options: Full :class:`RenderOptions`; overrides the image arguments above.
    """

    def __init__(
        self,
        camera: Camera | None = None,
        *,
        noise_px: float = 0.0,
        blur_px: float = 0.0,
        distortion: float | tuple[float, float] | list[float] = 0.0,
        texture: bool = False,
        seed: int | None = 0,
        depth: DepthPolicy = "desired",
        max_lost_frames: int = 3,
        ellipse_method: EllipseMethod = "moments",
        dot_radius_px: float = 4.0,
        options: RenderOptions | None = None,
    ) -> None:
        if depth not in DEPTH_POLICIES:
            raise ConfigurationError(
                f"depth must be one of {', '.join(DEPTH_POLICIES)}, got {depth!r}"
            )
        if not isinstance(max_lost_frames, int) or max_lost_frames < 0:
            raise ConfigurationError(
                f"max_lost_frames must be an integer >= 0, got {max_lost_frames!r}"
            )
        if ellipse_method not in ("moments", "contour"):
            raise ConfigurationError(
                f"ellipse_method must be 'moments' or 'contour', got {ellipse_method!r}"
            )
        if options is None:
            k = np.atleast_1d(np.asarray(distortion, dtype=float))
            if k.size not in (1, 2):
                raise ConfigurationError(f"distortion must be k1 or [k1, k2], got {distortion!r}")
            base = RenderOptions()
            options = RenderOptions(
                noise_px=float(noise_px),
                blur_px=float(blur_px),
                k1=float(k[0]),
                k2=float(k[1]) if k.size == 2 else 0.0,
                texture=bool(texture),
                seed=seed,
                levels=replace(base.levels, dot_radius_px=float(dot_radius_px)),
            )
        self.renderer = Renderer(camera, options)
        self.depth: DepthPolicy = depth
        self.max_lost_frames = max_lost_frames
        self.ellipse_method: EllipseMethod = ellipse_method
        self._tracker: DotTracker | None = None
        self._dot_tracker: ImageDotTracker | None = None
        self._terms: list[TermState] = []
        self._sets: dict[str, FloatArray] = {}
        self._detected: NDArray[np.bool_] = np.zeros(0, dtype=bool)
        self.all_dots_seen = False
        """Every tracked dot found in the last frame, at a finite position."""
        self._task_id: int | None = None
        self._dots_only = False  # every term is measured on the dots: read by windows
        self.feature_lost = False
        self.dots_uv: FloatArray = np.zeros((0, 2))
        """Pixel positions (N, 2) of the tracked dots after the last read (for overlays)."""
        self._bMc: FloatArray | None = None  # the camera pose of the last frame
        self._pose_misses = PoseMisses()  # depth = "pose": frames in a row without a pose

    @classmethod
    def from_config(cls, camera: Camera | None, table: Mapping[str, Any]) -> ImageSensor:
        """Build from a scenario's ``[sensor]`` table (``kind`` is ignored; other keys checked).

        Raises:
            ConfigurationError: an unknown key (the message lists the allowed ones).
        """
        opts = {k: v for k, v in table.items() if k != "kind"}
        unknown = sorted(set(opts) - set(_CONFIG_KEYS))
        if unknown:
            raise ConfigurationError(
                f"unknown [sensor] key(s) {', '.join(unknown)} for kind = 'image'; "
                f"allowed: kind, {', '.join(_CONFIG_KEYS)}"
            )
        try:
            return cls(camera, **opts)
        except (TypeError, ValueError) as exc:
            raise ConfigurationError(f"invalid [sensor] value: {exc}") from None

    @property
    def camera(self) -> Camera:
        """The camera intrinsics."""
        return self.renderer.camera

    def reset(self) -> None:
        """Forget the trackers and restart the noise stream."""
        self.renderer.reset()
        self._tracker = self._dot_tracker = self._bMc = None
        self._terms = []
        self._task_id = None
        self.feature_lost = False
        self.dots_uv = np.zeros((0, 2))
        self._pose_misses.reset()

    # -- set-up ---------------------------------------------------------------------------------

    def _plan(self, task: VisualTask, scene: Scene) -> None:
        """Map each term to its detector; all point sets share one dot tracker."""
        if self.depth == "desired" and task.inv_depth_star is None:
            raise ConfigurationError(
                "depth='desired' needs the task's desired inverse depths; build the task "
                "with VisualTask.from_desired_poses or use depth='estimated' or 'true'"
            )
        self._sets = {}
        self._terms = []
        for i, term in enumerate(task.terms):
            f = term.feature
            if (tag := tag_term(i, f, scene.object(term.target))) is not None:
                self._terms.append(tag)
            elif (plan := feature_adapter(f, "image_term")) and feature_adapter(f, "measure_image"):
                st = plan(i, f, term.target, scene, self._sets, self.depth)
                st.target = term.target
                self._terms.append(st)
            else:
                raise ConfigurationError(
                    f"term {i}: the image sensor cannot measure {type(f).__name__}"
                )
        n_dots = sum(len(p) for p in self._sets.values())
        self._tracker = self._dot_tracker = None
        if n_dots:
            opt = self.renderer.options
            self._dot_tracker = dot_tracker(n_dots, opt, self.max_lost_frames)
            # the blob-position tracker, for subclasses that detect blobs themselves
            self._tracker = DotTracker(n_dots, 25.0 + 3.0 * opt.blur_px, self.max_lost_frames)
        self._task_id = id(task)
        self._dots_only = all(st.on_dots and not isinstance(st, TagTerm) for st in self._terms)

    def _truth_uv(self, scene: Scene, bMc: FloatArray, t: float) -> FloatArray:
        """True pixel positions of every tracked dot (NaN behind the camera)."""
        out = []
        for name, pts in self._sets.items():
            cMo = scene.cMo(name, bMc, t)
            P = pts @ cMo[:3, :3].T + cMo[:3, 3]
            z = np.where(P[:, 2] > MIN_DEPTH, P[:, 2], np.nan)
            out.append(self.renderer.optics.to_pixel(P[:, :2] / z[:, None]))
        return np.vstack(out)

    # -- reading --------------------------------------------------------------------------------

    def read(
        self, task: VisualTask, scene: Scene, bMc: FloatArray, t: float, image: Any = None
    ) -> SensorReading:
        """Render (or take ``image``, e.g. a motion-blurred exposure of this pose and time:
        :mod:`redservo.vision.motion_blur`), detect and return the measured features."""
        first = self._task_id != id(task)
        if first:
            self._plan(task, scene)
        if image is None:  # computed where it is read: the tracker's windows (dots only)
            image = self.renderer.lazy_frame(scene, bMc, t)
        if not self._dots_only:
            image = pixels(image)
        truth: list[FloatArray | None] = [None] * len(task.terms)
        truth_d: list[FloatArray | None] = [None] * len(task.terms)
        if first or self.depth == "true":
            for i, term in enumerate(task.terms):
                try:
                    meas = term.feature.measure(scene.cMo(term.target, bMc, t))
                    truth[i], truth_d[i] = meas.s, meas.inv_depth
                except GeometryError:
                    pass
        notes: list[str] = []
        set_xy = self._read_dots(image, scene, bMc, t, first, notes)
        self.all_dots_seen = _all_seen(self._detected, set_xy)
        lost, gone = [], []
        for i, (term, st) in enumerate(zip(task.terms, self._terms)):
            s = self._measure(term.feature, st, image, set_xy, truth[i], notes, i)
            if s is None:
                st.lost += 1
                if st.s is None or st.lost > self.max_lost_frames:
                    gone.append(i)
                lost.append(i)
            else:
                if st.on_dots and st.lost_dots:
                    lost.append(i)
                    st.lost += 1
                    if st.lost > self.max_lost_frames:
                        gone.append(i)
                else:
                    st.lost = 0
                st.prev_s, st.s = st.s, s
        if gone:
            self.feature_lost = True
            what = ", ".join(f"{i} ({task.terms[i].target})" for i in gone)
            why = "; ".join(notes)
            reason = (
                f"{FEATURE_LOST}: term(s) {what} not detected for more than "
                f"{self.max_lost_frames} consecutive frame(s)" + (f" ({why})" if why else "")
            )
            return SensorReading(None, (), tuple(lost), reason, image)
        s_all = np.concatenate([st.s for st in self._terms if st.s is not None])
        dots = (self._sets, self._detected, set_xy)
        tried: dict[str, tuple[int, int] | None] = {}
        inv_depth = term_inv_depths(self.depth, task, self._terms, truth_d, dots, tried)
        if inv_depth is None:
            notes.append(f"no {self.depth} depth available yet")
            return SensorReading(None, (), tuple(lost), "; ".join(notes), image)
        no_pose = self._pose_misses.frame(tried)  # the depths kept said in the step's flag
        reading = SensorReading(
            s_all, inv_depth, tuple(lost), "; ".join(notes), image, no_pose=no_pose
        )
        return reading._replace(dots=set_xy.copy()) if len(set_xy) else reading

    def _read_dots(
        self,
        image: NDArray[np.uint8],
        scene: Scene,
        bMc: FloatArray,
        t: float,
        first: bool,
        notes: list[str],
    ) -> FloatArray:
        """Track the dots in the image; return their normalized positions (N, 2)."""
        if self._dot_tracker is None:
            return np.zeros((0, 2))
        start = self._truth_uv(scene, bMc, t) if first else None
        optics = self.renderer.optics
        shift = None if first else camera_shift(self._terms, optics, self.dots_uv, self._bMc, bMc)
        self._bMc = np.array(bMc, dtype=float)
        track = track_dots(self._dot_tracker, image, self.renderer.options, start, notes, shift)
        self._detected = track.detected
        self.dots_uv = track.uv
        return normalized_dots(self.renderer.optics, track.uv)

    def _measure(
        self,
        feature: Any,
        st: TermState,
        image: NDArray[np.uint8],
        set_xy: FloatArray,
        truth: FloatArray | None,
        notes: list[str],
        i: int,
    ) -> FloatArray | None:
        """One term's value, or None when it was not detected (the reason goes to ``notes``):
        a tag's (:mod:`redservo.vision.tag_sensor`), else the one its feature kind measures
        (``measure_image``, :mod:`redservo.vision.measure`)."""
        st.lost_dots = False
        if isinstance(st, TagTerm):
            s, why = measure_tag(image, self.renderer.optics, st, feature)
            if s is None:
                notes.append(f"term {i} ({st.kind}): {why}")
            return s
        measure = feature_adapter(feature, "measure_image")
        assert measure is not None  # checked when the task is planned
        out: FloatArray | None = measure(self, feature, st, image, set_xy, truth, notes, i)
        return out


def _all_seen(detected: NDArray[np.bool_], xy: FloatArray) -> bool:
    """Every dot ``detected`` this frame, at a finite position ``xy`` (N, 2): each term then
    takes its dots as they are (:func:`redservo.vision.measure.measured_dots`)."""
    return bool(detected.all()) and math.isfinite(float(np.add.reduce(xy, None)))


def tracking_gate_px(sensor: Any) -> float | None:
    """The gate (pixels, :func:`dot_gate_px`) of an image sensor's dot tracker, or None
    for a sensor that tracks no dots in an image (the ideal sensor)."""
    return dot_gate_px(sensor.renderer.options) if isinstance(sensor, ImageSensor) else None
