"""A camera sensor that sees the MuJoCo scene: render with light and shadow, then detect.

:class:`MujocoCamera` is an :class:`~redservo.vision.ImageSensor` whose image comes from
MuJoCo instead of our flat renderer: the camera carried by the :class:`MujocoArm`, the
arm itself, the targets as black discs printed on white paper (:mod:`redservo.physics.scenes`),
one shadow-casting light. The RGB image is turned to gray (``cv2.cvtColor``), blurred
(Gaussian, ``blur_px``) and noised (Gaussian, ``noise_px`` gray levels), then goes through
the image sensor's own pipeline: the dot detector (:func:`redservo.vision.dots.detect_dots`,
dark dots below :data:`DOT_THRESHOLD`), the tracker that never swaps dots, the moment
features, the depth policies and the ``feature_lost`` rule (docs/vision.md).

Measured terms: point and moment features of dot targets (point sets), a tag's corners
and pose features (:mod:`redservo.vision.tag_sensor`: OpenCV's decoder and our corner
refinement, on MuJoCo's textured card), a sphere's ellipse (dark matte, found by its edge
on rays from the prediction with each edge point's own gray levels and fitted by an
ellipse: :mod:`redservo.physics.shapes`) and a cylinder's two limbs (dark matte, the
image sensor's edge refinement along the predicted lines, each edge point at the level
midway between its own sides: :func:`redservo.vision.lines.refine_line`, with the edge
signs of the dark paint) and a line (drawn as a thin dark rod: the image of its axis from
its two limbs, :func:`redservo.physics.shapes.measure_rod`). A feature on an object of
another kind, or on an object that is not drawn, is refused with a
:class:`~redservo.errors.ConfigurationError`.

The image is the one of the arm's *current* MuJoCo state: ``read(task, scene, bMc, t)``
checks that ``bMc`` is the arm's camera pose (to 1 µm), so a sensor wired to another arm
than the simulated one fails loudly instead of measuring the wrong image.

Units: pixels, gray levels (0-255), seconds.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.features import CylinderFeature
from redservo.features.kinds import feature_adapter, feature_kind, resolve
from redservo.physics.arm import MujocoArm
from redservo.physics.scenes import LINE_ROD_RADIUS
from redservo.physics.shapes import RodTerm, limb_signs, measure_rod, measure_sphere_term
from redservo.scene import Line, Scene, Tag
from redservo.sensors import SensorReading
from redservo.vision.depth import DepthPolicy
from redservo.vision.dots import detect_dots
from redservo.vision.measure import noted
from redservo.vision.optics import require_cv2
from redservo.vision.render import Renderer, RenderOptions
from redservo.vision.sensor import ImageSensor
from redservo.vision.tag_sensor import TagTerm
from redservo.vision.terms import TermState

if TYPE_CHECKING:  # pragma: no cover
    from redservo.task import VisualTask

__all__ = ["MujocoCamera", "MujocoRenderer"]

DOT_THRESHOLD = 55.0
"""Gray level separating the ink from everything else (a choice from the materials and
lights of :mod:`redservo.physics.arm`): ink (reflectance 0.04) in full light is about 10,
paper (0.93) in the arm's shadow (ambient 0.2 + head light 0.25) about 107, the background
about 115; 55 is halfway between ink and shadowed paper."""

POSE_TOLERANCE = 1e-6
"""How far (m, and rad per matrix entry) ``bMc`` may be from the arm's camera pose."""


class MujocoRenderer(Renderer):
    """:class:`~redservo.vision.render.Renderer` whose image is MuJoCo's (module docstring)."""

    def __init__(self, arm: MujocoArm, options: RenderOptions) -> None:
        super().__init__(arm.camera, options)
        self.arm = arm
        self.last_rgb: NDArray[np.uint8] | None = None
        """The last RGB image MuJoCo rendered (H, W, 3), before blur and noise."""

    def render(self, scene: Scene, bMc: FloatArray, t: float = 0.0) -> NDArray[np.uint8]:
        """The gray image (H, W) uint8 of the arm's camera now, objects at ``t`` (s).

        ``bMc`` must be :meth:`MujocoArm.camera_pose`: the camera in the base frame, or for a
        camera fixed in the world (eye-to-hand) ``eMc(q)``, the fixed camera seen from the
        effector, which the eye-to-hand robot's ``fkine`` hands the sensor; a pose of any
        other arm state fails.

        Raises:
            ConfigurationError: ``bMc`` is not the arm's camera pose (another arm's state).
        """
        err = float(np.abs(np.asarray(bMc) - self.arm.camera_pose()).max())
        if not err <= POSE_TOLERANCE:
            raise ConfigurationError(
                f"the MuJoCo camera renders its arm's current state, {err:.3g} away from the "
                "camera pose asked for; drive that arm (MujocoActuator / MujocoRobot)",
                argument="bMc",
            )
        cv2 = require_cv2()
        rgb = self.arm.render(t)
        self.last_rgb = rgb
        gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(np.float32)
        opt = self.options
        if opt.blur_px > 0.0:
            gray = cv2.GaussianBlur(gray, (0, 0), sigmaX=opt.blur_px, sigmaY=opt.blur_px)
        if opt.noise_px > 0.0:
            gray = cv2.scaleAdd(self._noise(), float(opt.noise_px), gray)
        out: NDArray[np.uint8] = cv2.add(gray, 0.0, dtype=cv2.CV_8U)
        return out


class MujocoCamera(ImageSensor):
    """The features of a task measured in the MuJoCo arm's camera image (module docstring).

    Args:
        arm: The arm (with the scene's objects) whose camera renders.
        noise_px: Gaussian pixel noise, std in gray levels (0-255).
        blur_px: Gaussian blur, std in pixels.
        seed: Seed of the noise.
        depth: ``"desired"``, ``"estimated"`` or ``"true"`` (:mod:`redservo.vision.depth`).
        max_lost_frames: A term lost for longer ends the run (``feature_lost``).
    """

    def __init__(
        self,
        arm: MujocoArm,
        *,
        noise_px: float = 0.0,
        blur_px: float = 0.0,
        seed: int | None = 0,
        depth: DepthPolicy = "desired",
        max_lost_frames: int = 3,
    ) -> None:
        super().__init__(
            arm.camera,
            noise_px=noise_px,
            blur_px=blur_px,
            seed=seed,
            depth=depth,
            max_lost_frames=max_lost_frames,
        )
        self.arm = arm
        self.renderer = MujocoRenderer(arm, self.renderer.options)
        self._rods: dict[int, RodTerm] = {}
        self._frame: tuple[Scene, FloatArray, float] | None = None

    def _plan(self, task: VisualTask, scene: Scene) -> None:
        """As the image sensor's, after checking that each term's object is drawn and is
        of the kind its feature observes (``FeatureKind.obj``) or is a tag."""
        for i, term in enumerate(task.terms):
            obj = scene.object(term.target)
            on_tag = isinstance(obj, Tag)
            kind = feature_kind(term.feature)
            if not (on_tag or feature_adapter(term.feature, "measure_image")):
                raise ConfigurationError(
                    f"term {i}: the MuJoCo camera measures point and moment features of dot "
                    "targets, spheres, cylinders, lines and the features of tags, not "
                    f"{type(term.feature).__name__}",
                    argument="features",
                )
            if term.target in self.arm.skipped or term.target not in self.arm.drawn:
                raise ConfigurationError(
                    f"term {i}: object {term.target!r} is not drawn in the MuJoCo scene "
                    "(only coplanar point sets, tags, spheres, cylinders and lines are)",
                    argument="features",
                )
            shape = resolve(kind.obj) if kind is not None and kind.obj and not on_tag else None
            if shape is not None and not isinstance(obj, shape):
                raise ConfigurationError(
                    f"term {i}: a {type(term.feature).__name__} is measured on a drawn "
                    f"{shape.__name__}; {term.target!r} is a {type(obj).__name__}",
                    argument="features",
                )
        self._rods = {}
        super()._plan(task, scene)

    live = True
    """It renders the physics' present state (:mod:`redservo.sensors.timing`)."""

    def read(
        self, task: VisualTask, scene: Scene, bMc: FloatArray, t: float, image: Any = None
    ) -> SensorReading:
        """As :meth:`ImageSensor.read`; keeps the frame's poses for a rod's first frame."""
        self._frame = (scene, np.asarray(bMc, dtype=float), float(t))
        return super().read(task, scene, bMc, t, image)

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
        """The kind's MuJoCo measurement (``measure_mujoco``: a sphere by its edge, a
        cylinder's limbs with their edge signs known from the dark paint, a line as a rod);
        other terms as the base."""
        measure = None if isinstance(st, TagTerm) else feature_adapter(feature, "measure_mujoco")
        if measure is None:
            return super()._measure(feature, st, image, set_xy, truth, notes, i)
        st.lost_dots = False
        out: FloatArray | None = measure(self, feature, st, image, set_xy, truth, notes, i)
        return out

    def _read_dots(
        self,
        image: NDArray[np.uint8],
        scene: Scene,
        bMc: FloatArray,
        t: float,
        first: bool,
        notes: list[str],
    ) -> FloatArray:
        """Detect dark dots (:data:`DOT_THRESHOLD`) and track them; normalized positions (N, 2)."""
        if self._tracker is None:
            return np.zeros((0, 2))
        blur = self.renderer.options.blur_px
        det = detect_dots(
            image,
            threshold=DOT_THRESHOLD,
            polarity="dark",
            min_size_px=2.0,
            max_size_px=0.25 * min(image.shape),
            pad_px=max(2.5, 3.0 * blur + 1.0),
        )
        if first:
            self._tracker.start(self._truth_uv(scene, bMc, t))
        track = self._tracker.update(det.uv)
        if track.n_blobs != self._tracker.n_dots:
            notes.append(f"found {track.n_blobs} dot blob(s), expected {self._tracker.n_dots}")
        if det.n_border:
            notes.append(f"{det.n_border} blob(s) cut by the image border")
        self._detected = track.detected
        self.dots_uv = track.uv
        return self.renderer.optics.to_normalized(track.uv)


def measure_mujoco_sphere(
    sensor: MujocoCamera,
    feature: Any,
    st: TermState,
    image: NDArray[np.uint8],
    set_xy: FloatArray,
    truth: FloatArray | None,
    notes: list[str],
    i: int,
) -> FloatArray | None:
    """A sphere by its edge (:func:`~redservo.physics.shapes.measure_sphere_term`)."""
    blur = sensor.renderer.options.blur_px
    s, why = measure_sphere_term(image, sensor.renderer.optics, st, feature, truth, blur)
    return noted(s, why, st, notes, i)


def measure_mujoco_cylinder(
    sensor: MujocoCamera,
    feature: Any,
    st: TermState,
    image: NDArray[np.uint8],
    set_xy: FloatArray,
    truth: FloatArray | None,
    notes: list[str],
    i: int,
) -> FloatArray | None:
    """A cylinder's limbs with their edge signs known from the dark paint
    (:func:`~redservo.physics.shapes.limb_signs`), then as the image sensor."""
    if not st.signs and truth is not None:
        st.signs = limb_signs(truth)
    return ImageSensor._measure(sensor, feature, st, image, set_xy, truth, notes, i)


def measure_mujoco_line(
    sensor: MujocoCamera,
    feature: Any,
    st: TermState,
    image: NDArray[np.uint8],
    set_xy: FloatArray,
    truth: FloatArray | None,
    notes: list[str],
    i: int,
) -> FloatArray | None:
    """A line drawn as a thin dark rod: the image of its axis from its two limbs
    (:func:`~redservo.physics.shapes.measure_rod`)."""
    assert sensor._frame is not None  # set by read()
    scene, bMc, t = sensor._frame
    if i not in sensor._rods:
        obj = scene.object(st.target)
        assert isinstance(obj, Line)  # checked when planned: a line feature observes a line
        rod_feature = CylinderFeature(LINE_ROD_RADIUS, obj.direction, obj.point)
        sensor._rods[i] = RodTerm(rod_feature, st.target)
    rod = sensor._rods[i]
    cMo = scene.cMo(rod.target, bMc, t) if rod.state.s is None else None
    s, why = measure_rod(image, sensor.renderer, rod, cMo, truth if st.s is None else st.s)
    return noted(s, why, st, notes, i)
