"""Camera and hand-eye calibration through OpenCV (extra ``redservo[vision]``).

* :func:`calibrate_camera` (:mod:`~redservo.calibration.intrinsics`): a chessboard or a
  circle grid in several images, ``cv2.findChessboardCorners`` + ``cv2.cornerSubPix`` (or
  ``cv2.findCirclesGrid``), then ``cv2.calibrateCamera``: the
  :class:`~redservo.camera.Camera` with its distortion and the RMS reprojection error;
  ``redservo calibrate`` writes it as an OpenCV file (:func:`redservo.calibration.files.save_camera`).
* :func:`hand_eye` (:mod:`~redservo.calibration.hand_eye`): from pairs of robot poses
  ``wMe`` and target poses ``cMo``, ``cv2.calibrateHandEye`` gives ``eMc`` (eye-in-hand) or,
  with the robot poses inverted, the fixed camera's ``wMc`` (eye-to-hand), with the
  residuals; ``redservo calibrate-hand-eye``.
* :mod:`~redservo.calibration.synthetic`: images of a chessboard or circle grid seen by a
  known camera (with distortion), for tests and for trying the commands.
"""

from redservo.calibration.hand_eye import HandEyeResult, hand_eye, load_pose_pairs
from redservo.calibration.intrinsics import CalibrationResult, calibrate_camera, grid_points

__all__ = [
    "CalibrationResult",
    "HandEyeResult",
    "calibrate_camera",
    "grid_points",
    "hand_eye",
    "load_pose_pairs",
]
