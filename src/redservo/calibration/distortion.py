"""Which lens distortion a calibration fits: the terms of redservo's (OpenCV's ``plumb_bob``)
model ``k1, k2, p1, p2, k3`` (:class:`redservo.camera.Camera`) that ``cv2.calibrateCamera``
estimates, the others held at zero.

=========  =======================  =====================================================
model      fitted                   OpenCV flags
=========  =======================  =====================================================
``none``   nothing (a pinhole)      ``CALIB_FIX_K1 | K2 | K3 | CALIB_ZERO_TANGENT_DIST``
``k1``     ``k1``                   ``CALIB_FIX_K2 | CALIB_FIX_K3 | CALIB_ZERO_TANGENT_DIST``
``k1k2``   ``k1, k2``               ``CALIB_FIX_K3 | CALIB_ZERO_TANGENT_DIST``
``k1k2p``  ``k1, k2, p1, p2``       ``CALIB_FIX_K3``
``full5``  ``k1, k2, p1, p2, k3``   none
=========  =======================  =====================================================

``auto`` (:func:`choose_model`) fits no more terms than the views support: ``full5`` from
:data:`AUTO_FULL5` distinct views covering at least half the image, ``k1k2p`` from
:data:`AUTO_K1K2P` views covering :data:`~redservo.calibration.views.MIN_COVERAGE`, ``k1k2``
from :data:`AUTO_K1K2` views, else ``k1``; it says why.
"""

from __future__ import annotations

from typing import Any

from redservo.errors import ConfigurationError

__all__ = ["AUTO_FULL5", "AUTO_K1K2", "AUTO_K1K2P", "MODELS", "choose_model", "model_flags"]

MODELS = ("none", "k1", "k1k2", "k1k2p", "full5")
"""The distortion models, fewest terms first (module docstring)."""
AUTO_FULL5 = 15
"""Distinct views from which ``auto`` fits ``k3`` too (with half the image covered)."""
AUTO_K1K2P = 8
"""Distinct views from which ``auto`` fits the tangential terms."""
AUTO_K1K2 = 5
"""Distinct views from which ``auto`` fits ``k2``."""


def model_flags(cv2: Any, model: str) -> int:
    """The ``cv2.calibrateCamera`` flags of ``model`` (with ``CALIB_FIX_SKEW`` when known).

    Raises:
        ConfigurationError: an unknown model.
    """
    if model not in MODELS:
        raise ConfigurationError(
            f"distortion must be one of {', '.join(MODELS)} or auto, got {model!r}",
            argument="distortion",
        )
    names = {
        "none": ("CALIB_FIX_K1", "CALIB_FIX_K2", "CALIB_FIX_K3", "CALIB_ZERO_TANGENT_DIST"),
        "k1": ("CALIB_FIX_K2", "CALIB_FIX_K3", "CALIB_ZERO_TANGENT_DIST"),
        "k1k2": ("CALIB_FIX_K3", "CALIB_ZERO_TANGENT_DIST"),
        "k1k2p": ("CALIB_FIX_K3",),
        "full5": (),
    }[model]
    flags = getattr(cv2, "CALIB_FIX_SKEW", 0)
    for name in names:
        flags |= getattr(cv2, name)
    return int(flags)


def choose_model(views: int, covered: float) -> tuple[str, str]:
    """``(model, why)`` for ``auto`` from the number of distinct views and the fraction of the
    image the pattern covered (module docstring)."""
    from redservo.calibration.views import MIN_COVERAGE

    seen = f"{views} distinct views covering {covered:.0%} of the image"
    if views >= AUTO_FULL5 and covered >= 0.5:
        return "full5", f"auto: {seen}"
    if views >= AUTO_K1K2P and covered >= MIN_COVERAGE:
        return "k1k2p", f"auto: {seen}; k3 needs {AUTO_FULL5} views over half the image"
    if views >= AUTO_K1K2:
        need = f"{AUTO_K1K2P} views over {MIN_COVERAGE:.0%} of the image"
        return "k1k2", f"auto: {seen}; p1, p2 need {need}"
    return "k1", f"auto: {seen}; k2 needs {AUTO_K1K2} views"
