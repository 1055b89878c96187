"""The simulation loop's check that every target object stays in view.

At every iteration (with ``check_image``), every point of each target object the task looks
at must be in front of the camera and within its image less ``image_margin_px``, else the run
ends ``target_lost``. :class:`ImageCheck` makes that check in one compiled call for targets
that are point sets seen through a camera without distortion
(:func:`redservo.kernels.loop_image.targets_in_image`: the camera points of
:func:`~redservo.control.objectives.visible_points` by the same operations, then
:func:`_in_image`'s test on all of them); any other target, a lens, or a point the kernel
cannot decide takes the numpy code. Units: metres, pixels, seconds.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.control.objectives import visible_points
from redservo.kernels import lazy
from redservo.kernels._jit import COMPILED
from redservo.scene import PointSet, Scene, Static

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import in_image as _KI
    from redservo.kernels import loop_image as _KL
else:
    _KI = lazy("in_image")
    _KL = lazy("loop_image")

__all__ = ["ImageCheck"]


def _in_image(cam: Camera, P: FloatArray, margin_px: float) -> bool:
    """Every point of ``P`` (N, 3) (m, camera frame) in front of the camera and within its
    image less ``margin_px`` (pixels): one compiled call for a camera without distortion
    (:func:`redservo.kernels.in_image.points_in_image`), else numpy's code."""
    if not cam.distorted and P.dtype == np.float64 and P.ndim == 2 and P.shape[1] == 3:
        m = float(margin_px)
        intrinsics = (float(cam.px), float(cam.py), float(cam.u0), float(cam.v0))
        inside = _KI.points_in_image(
            np.ascontiguousarray(P), intrinsics, (m, cam.width - m, cam.height - m)
        )
        if inside >= 0:
            return inside == 1
    if np.any(P[:, 2] <= 1e-9):
        return False
    xy = P[:, :2] / P[:, 2:3]
    return bool(np.all(cam.in_image(xy, margin_px=margin_px)))


class ImageCheck:
    """``check(bMc, t)``: every point of every target of a run in view (module docstring).

    Args:
        scene: The run's scene.
        targets: The names of the objects the task looks at.
        camera: The camera whose image bounds the points.
        margin_px: The margin (pixels) inside the image's border.
    """

    def __init__(self, scene: Scene, targets: list[str], camera: Camera, margin_px: float) -> None:
        self.scene, self.targets, self.camera, self.margin = scene, targets, camera, margin_px
        objs = [scene.object(name) for name in targets]
        sets = [o for o in objs if isinstance(o, PointSet) and type(o) is PointSet]
        self.fast = COMPILED and bool(objs) and not camera.distorted and len(sets) == len(objs)
        if not self.fast:
            return
        self.pts = np.ascontiguousarray(np.concatenate([o.points for o in sets]), dtype=np.float64)
        self.starts = np.cumsum(np.array([0] + [len(o.points) for o in sets], dtype=np.int64))
        m = float(margin_px)
        self.intrinsics = (float(camera.px), float(camera.py), float(camera.u0), float(camera.v0))
        self.bounds = (m, camera.width - m, camera.height - m)
        base = scene._target_pose(targets[0], 0.0)[0]
        self.has_base = bool(base.shape[0])
        self.bMw = np.ascontiguousarray(base if self.has_base else np.eye(4), dtype=float)
        self.static: FloatArray | None = None
        if all(type(o.trajectory) is Static for o in sets):
            self.static = self._poses(0.0)

    def _poses(self, t: float) -> FloatArray:
        """The targets' poses ``wMo`` at ``t`` (s) as the kernel takes them (1, sets, 4, 4)."""
        scene = self.scene
        return np.array([[scene._target_pose(name, t)[1] for name in self.targets]], dtype=float)

    def __call__(self, bMc: FloatArray, t: float) -> bool:
        """Whether every target point is in view at the camera pose ``bMc`` (4x4) and ``t``."""
        if self.fast:
            wMo = self.static if self.static is not None else self._poses(t)
            cam = np.ascontiguousarray(bMc, dtype=float)[None]
            args = (self.pts, self.starts, self.intrinsics, self.bounds)
            inside = _KL.targets_in_image(cam, wMo, self.bMw, self.has_base, *args)
            if inside >= 0:
                return inside == 1
        scene, cam_, m = self.scene, self.camera, self.margin
        return all(_in_image(cam_, visible_points(scene, n, bMc, t), m) for n in self.targets)
