"""Camera intrinsics files: read and write OpenCV calibration files and ROS ``camera_info``.

:func:`load_camera` reads, through ``cv2.FileStorage`` (extra ``redservo[vision]``):

* **OpenCV** YAML, XML or JSON as ``cv2.calibrateCamera`` users (and ``redservo
  calibrate``) write it: ``camera_matrix`` (3x3 ``opencv-matrix``),
  ``distortion_coefficients`` (1x4, 1x5 or longer with trailing zeros), ``image_width``,
  ``image_height``;
* **ROS 1** ``camera_info`` YAML (``camera_calibration``'s file): the same keys, with the
  matrices written as ``{rows, cols, data: [...]}``;
* **ROS flat** ``camera_info`` (``rostopic echo`` / ``ros2 topic echo`` of a
  ``sensor_msgs/CameraInfo``): ``K`` (9 numbers), ``D``, ``width``, ``height`` (or their
  lower-case ROS 2 spellings ``k``, ``d``).

The distortion model must be OpenCV's radial-tangential one (ROS ``plumb_bob``; the
``rational_polynomial`` model only with its extra coefficients zero). Pixel convention:
the files put pixel centres on the integers (OpenCV, ROS), redservo on the half-integers
(:mod:`redservo.camera`), so ``u0 = cx + 0.5``, ``v0 = cy + 0.5`` on reading and the
reverse on writing. Any problem is one :class:`~redservo.errors.ConfigurationError`
naming the file and the key (a scenario turns it into a ScenarioError under
``camera.file``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from redservo.camera import DISTORTION_NAMES, Camera
from redservo.errors import ConfigurationError, RedservoError

__all__ = ["load_camera", "save_camera"]

_PIXEL_CENTRE = 0.5
"""redservo's ``u0`` minus OpenCV's ``cx`` (pixels): the pixel-centre conventions."""


def _cv2() -> Any:
    from redservo.vision.optics import require_cv2

    return require_cv2()


def _numbers(node: Any) -> np.ndarray | None:
    """The numbers of a FileStorage node: an opencv-matrix, a ``{data: [...]}`` map or a
    sequence; None when the node is absent."""
    if node is None or node.empty() or node.isNone():
        return None
    if node.isMap():
        data = node.getNode("data")
        if not data.empty() and data.isSeq():
            node = data
        else:
            mat = node.mat()
            return None if mat is None else np.asarray(mat, dtype=float).ravel()
    if node.isSeq():
        return np.array([node.at(i).real() for i in range(node.size())], dtype=float)
    if node.isReal() or node.isInt():
        return np.array([node.real()], dtype=float)
    return None


def _first(fs: Any, *keys: str) -> tuple[str, Any]:
    """The first of ``keys`` present in the file (and its node), else ``(keys[0], None)``."""
    for key in keys:
        node = fs.getNode(key)
        if not node.empty() and not node.isNone():
            return key, node
    return keys[0], None


def load_camera(path: str | os.PathLike[str]) -> Camera:
    """Read a :class:`~redservo.camera.Camera` from an OpenCV or ROS intrinsics file.

    Args:
        path: The file (``.yaml``, ``.yml``, ``.xml`` or ``.json``; module docstring).

    Raises:
        ConfigurationError: the file is missing or unreadable, a key is missing or has
            the wrong size, the distortion model is not radial-tangential, or the values
            make no camera; the message names the file and the key.
    """
    p = Path(path)
    if not p.is_file():
        raise ConfigurationError(f"{p}: no such camera file", argument="file")
    cv2 = _cv2()
    try:
        fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # a parse error may surface as either
        text = str(getattr(exc, "__cause__", None) or exc).strip()
        msg = text.splitlines()[-1] if text else "unreadable"
        raise ConfigurationError(
            f"{p}: not an OpenCV/ROS camera file (YAML, XML or JSON): {msg}", argument="file"
        ) from None
    try:
        return _read(fs, p)
    finally:
        fs.release()


def _read(fs: Any, p: Path) -> Camera:
    def bad(key: str, what: str) -> ConfigurationError:
        return ConfigurationError(f"{p}: key '{key}': {what}", argument=key)

    if not fs.isOpened():
        raise ConfigurationError(f"{p}: cannot open as a camera file", argument="file")
    kkey, knode = _first(fs, "camera_matrix", "K", "k")
    K = _numbers(knode)
    if K is None:
        raise bad("camera_matrix", "missing: give camera_matrix (OpenCV, ROS 1) or K (ROS)")
    if K.size != 9 or not np.all(np.isfinite(K)):
        raise bad(kkey, f"expected 9 finite numbers (a 3x3 matrix), got {K.size}")
    K = K.reshape(3, 3)
    if abs(K[1, 0]) + abs(K[2, 0]) + abs(K[2, 1]) > 0 or K[2, 2] != 1.0:
        raise bad(kkey, "not a camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]]")
    if K[0, 1] != 0.0:
        raise bad(kkey, f"skew {K[0, 1]:g} is not supported (redservo's cameras have none)")
    model_node = fs.getNode("distortion_model")
    model = "plumb_bob" if model_node.empty() or model_node.isNone() else model_node.string()
    dkey, dnode = _first(fs, "distortion_coefficients", "D", "d")
    D = _numbers(dnode)
    D = np.zeros(5) if D is None else D
    if model not in ("plumb_bob", "radtan", "rational_polynomial", ""):
        raise bad("distortion_model", f"{model!r} is not supported; allowed: plumb_bob")
    if D.size < 4 or np.any(D[5:] != 0.0) or not np.all(np.isfinite(D)):
        raise bad(
            dkey,
            f"expected 4 or 5 finite coefficients (k1, k2, p1, p2[, k3]); got {D.size} "
            f"({D.tolist()}): only the radial-tangential model is supported",
        )
    D = np.concatenate([D[:5], np.zeros(5 - min(D.size, 5))])
    size: list[int] = []
    for keys in (("image_width", "width"), ("image_height", "height")):
        key, node = _first(fs, *keys)
        value = _numbers(node)
        if value is None or value.size != 1 or value[0] != int(value[0]) or value[0] < 1:
            raise bad(key, "missing or not a positive integer (pixels)")
        size.append(int(value[0]))
    kw = dict(zip(DISTORTION_NAMES, map(float, D), strict=True))
    try:
        return Camera(
            px=float(K[0, 0]),
            py=float(K[1, 1]),
            u0=float(K[0, 2]) + _PIXEL_CENTRE,
            v0=float(K[1, 2]) + _PIXEL_CENTRE,
            width=size[0],
            height=size[1],
            **kw,
        )
    except RedservoError as exc:
        raise bad(kkey, str(exc)) from None


def save_camera(path: str | os.PathLike[str], camera: Camera, **extra: float | int | str) -> Path:
    """Write ``camera`` as an OpenCV calibration file (YAML, XML or JSON by the suffix)
    that :func:`load_camera`, OpenCV and ROS's ``camera_calibration_parsers`` read back.

    Args:
        path: Output file.
        camera: The intrinsics.
        extra: Further scalar entries (e.g. ``rms_px``, ``n_images``), written as they are.

    Returns:
        The path written.
    """
    cv2 = _cv2()
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    K = np.array(
        [
            [camera.px, 0.0, camera.u0 - _PIXEL_CENTRE],
            [0.0, camera.py, camera.v0 - _PIXEL_CENTRE],
            [0.0, 0.0, 1.0],
        ]
    )
    fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
    try:
        fs.write("image_width", int(camera.width))
        fs.write("image_height", int(camera.height))
        fs.write("camera_matrix", K)
        fs.write("distortion_model", "plumb_bob")
        fs.write("distortion_coefficients", np.array([camera.distortion], dtype=float))
        for key, value in extra.items():
            fs.write(key, value)
    finally:
        fs.release()
    return p
