"""The target's pose for the ``predictive`` law's moment model from the tracked dots (PnP).

The moment model (:mod:`redservo.redundancy.predictive_moments`) predicts the six moment
features from the target's pose ``bMo``. With the ideal sensor it estimates the pose from
the features and the measured object plane; through a camera the plane is only the image
sensor's depth policy, and the six features alone leave the target's tilt ambiguous
(docs/predictive.md): the model's goal is then wrong and the law wanders. The image sensor
tracks the target's four dots, whose positions on the object the feature knows
(``points_o``), so the pose comes from them by PnP (:func:`redservo.vision.pnp.dot_pose`,
OpenCV with the bound camera's intrinsics, warm-started at the previous frame's pose):

* a loop that has the frames (the simulator: :meth:`Predictive.observe_dots
  <redservo.redundancy.predictive.Predictive.observe_dots>`) gives the dots of the frame
  the controller uses and its **age** (s, from the exposure to now);
* the camera where the frame was exposed is the model robot's at the joints of ``age``
  ago (the law's own past joints, one a period, interpolated; the oldest when the run is
  younger), so ``bMo = bMc(q_exposure) cMo`` is the target in the base frame, to which the
  model robot's kinematics bring the camera of every predicted period;
* a frame whose pose PnP cannot give (fewer than four dots, a dot behind the camera, a
  reprojection error above :data:`~redservo.vision.pnp.MAX_RMS_PX`) is counted
  (:attr:`DotPoses.failures`) and flagged: the step's result carries the typed event
  :attr:`~redservo.redundancy.flags.Flag.NO_POSE` (:meth:`DotPoses.flagged`; value: the
  frames in a row without a pose), which the run's log, summary and the campaign's flag
  counts keep; the model falls back to its documented estimate from the features.

Units: metres, seconds, normalized image coordinates.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import flagbits as fb
from redservo.redundancy.base import LawResult
from redservo.redundancy.messages import events

__all__ = ["DotPoses"]


class DotPoses:
    """The last frame's dots, the past joints and the last PnP pose ``bMo`` (4, 4; base
    frame, m) of one run (module docstring)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget the frame, the joints and the pose (start of a run)."""
        self.dots: FloatArray | None = None
        self.age = 0.0
        self.bMo: FloatArray | None = None
        self._past: list[FloatArray] = []
        self.poses = 0
        """Frames whose pose PnP gave."""
        self.failures = 0
        """Frames whose pose PnP could not give (the model fell back to the features)."""
        self.last_failed = False
        self.in_a_row = 0
        """Calls in a row whose frame gave no pose (0 after a pose)."""
        self._why = (0, 0, 0)  # the last failure's source bit, finite dots, target points

    def frame(self, dots: FloatArray, age: float) -> None:
        """The dots (N, 2; normalized) of the frame in use, exposed ``age`` seconds ago."""
        self.dots = np.array(dots, dtype=float).reshape(-1, 2)
        self.age = max(0.0, float(age))

    def joints_at_exposure(self, q: FloatArray, dt: float) -> FloatArray:
        """Record the joints ``q`` (n,) of this period (s, ``dt``) and return those of
        :attr:`age` seconds ago (interpolated; the oldest kept when the run is younger)."""
        back = self.age / dt if dt > 0 else 0.0
        self._past.append(np.array(q, dtype=float))
        del self._past[: -(int(np.ceil(back)) + 2)]
        pos = max(0.0, len(self._past) - 1 - back)
        i = min(int(pos), len(self._past) - 1)
        j = min(i + 1, len(self._past) - 1)
        w = pos - i
        return np.asarray((1.0 - w) * self._past[i] + w * self._past[j])

    def target_pose(
        self, robot: Any, points_o: FloatArray, q: FloatArray, dt: float, camera: Any
    ) -> FloatArray | None:
        """``bMo`` (4, 4) from the frame's dots, or None (no frame, dots that are not the
        target's, or no accepted PnP pose: counted in :attr:`failures`)."""
        from redservo.vision.pnp import dot_pose

        q_exp = self.joints_at_exposure(q, dt)
        self.last_failed = False
        if self.dots is None:
            return None
        finite = int(np.isfinite(self.dots).all(axis=1).sum())
        if self.dots.shape[0] != points_o.shape[0] or finite < self.dots.shape[0]:
            self._failed(fb.POSE_FEW_DOTS, finite, points_o.shape[0])
            return None
        bMc = robot.kinematics(q_exp, check_limits=False)[0]
        guess = None if self.bMo is None else np.linalg.inv(bMc) @ self.bMo
        pose = dot_pose(points_o, self.dots, camera, guess)
        if pose is None:
            self._failed(fb.POSE_REJECTED, finite, points_o.shape[0])
            return None
        self.poses += 1
        self.in_a_row = 0
        self.bMo = bMc @ pose.cMo
        return self.bMo

    def _failed(self, why: int, dots: int, points: int) -> None:
        self.failures += 1
        self.in_a_row += 1
        self.last_failed = True
        self._why = (why, dots, points)

    def flagged(self, res: LawResult) -> LawResult:
        """``res`` with the ``no-pose`` event (:attr:`~redservo.redundancy.flags.Flag.NO_POSE`)
        when the frame of this call gave no pose (the failure is then consumed: a later call
        without a PnP attempt is not flagged); ``res`` itself otherwise."""
        if not self.last_failed:
            return res
        self.last_failed = False
        why, dots, points = self._why
        vals = np.zeros(fb.N_FLAGS)
        src = np.zeros(fb.N_FLAGS, dtype=np.int64)
        vals[fb.NO_POSE], src[fb.NO_POSE] = float(self.in_a_row), why
        ev = events(1 << fb.NO_POSE, vals, src, dots=dots, points=points)
        d = res.diagnostics
        return LawResult(res.qdot, dataclasses.replace(d, events=(*d.events, *ev)))
