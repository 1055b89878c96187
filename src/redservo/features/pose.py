"""Pose-based features (PBVS): a translation ``t`` and a rotation ``θu`` from a measured pose.

The features of ViSP's ``vpFeatureTranslation`` and ``vpFeatureThetaU``, from the object's pose
``cMo`` (measured, e.g. by :func:`redservo.vision.detect_tags`) and the desired pose ``c*Mo``
(``desired``, 4x4; the object's pose in the desired camera frame). With ``v_c = (v, ω)`` the
camera twist in the current camera frame (Chaumette & Hutchinson 2006, Part I, §IV):

=============  ==========================  =======  ===============================
variant        ``s``                       ``s*``   ``L_s`` (3 x 6)
=============  ==========================  =======  ===============================
``cdMc``  (t)  ``c*t_c``: the camera        0        ``[c*R_c, 0]``
               origin in the desired frame
``cMo``   (t)  ``c t_o``: the object        ``c*t_o`` ``[-I, [c t_o]x]``
               origin in the camera frame
``cMcd``  (t)  ``c t_c*``: the desired      0        ``[-I, [c t_c*]x]``
               camera origin, camera frame
``cdRc``  (θu) ``θu`` of ``c*R_c``          0        ``[0, L_θu(θu)]``
``cRcd``  (θu) ``θu`` of ``c R_c*``         0        ``[0, -L_θu(-θu)]``
=============  ==========================  =======  ===============================

``L_θu(θu) = I + θ/2 [u]x + (1 - sinc θ / sinc²(θ/2)) [u]x²`` (the inverse of the right
Jacobian of SO(3); CH06 §IV, whose sign of the ``θ/2`` term depends on the rotation ``u`` is
taken from); ``[a]x`` is the cross-product matrix. ``tests/test_features_pose.py`` checks every row against finite
differences. The classic PBVS task ``(c*t_c, θu of c*R_c)`` with ``λ`` decouples translation
and rotation (the camera origin moves on a straight line); ``(c t_o, θu of c*R_c)`` keeps the
object's origin on a straight line in the image.

Inverse-depth parameters: none (an empty array) except for ``cdMc``, whose ``L`` needs the
rotation ``c*R_c``: its parameters are ``(θu, 1)`` of ``c*R_c`` and ``L`` uses ``θu / w`` (the
fourth entry ``w``), so the task's depth options act on it meaningfully: ``desired`` gives
``c*R_c = I`` (ViSP's ``L*``), ``mean`` the half rotation, and a depth-estimate factor
(which divides every parameter) cancels.
"""

from __future__ import annotations

from typing import Literal, get_args

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform, as_vector
from redservo.errors import ConfigurationError
from redservo.features.base import Feature, Measurement
from redservo.features.kinds import FeatureKind
from redservo.spatial import inverse, matrix_to_rotvec, rotvec_to_matrix, skew

__all__ = [
    "ROTATION_VARIANTS",
    "TRANSLATION_VARIANTS",
    "LogDepth",
    "PoseThetaU",
    "PoseTranslation",
    "RotationVariant",
    "TranslationVariant",
    "thetau_interaction",
]

TranslationVariant = Literal["cdMc", "cMo", "cMcd"]
RotationVariant = Literal["cdRc", "cRcd"]
TRANSLATION_VARIANTS: tuple[str, ...] = get_args(TranslationVariant)
ROTATION_VARIANTS: tuple[str, ...] = get_args(RotationVariant)
_EMPTY = np.zeros(0)


def _sinc(x: float) -> float:
    return 1.0 if abs(x) < 1e-8 else float(np.sin(x) / x)


def thetau_interaction(theta_u: ArrayLike) -> FloatArray:
    """``L_θu`` (3, 3) with ``d(θu)/dt = L_θu ω`` for ``R' = R [ω]x`` (module docstring)."""
    tu = as_vector(theta_u, "theta_u", 3)
    theta = float(np.linalg.norm(tu))
    if theta < 1e-12:
        return np.eye(3)
    U = skew(tu / theta)
    c = 1.0 - _sinc(theta) / _sinc(0.5 * theta) ** 2
    return np.asarray(np.eye(3) + 0.5 * theta * U + c * (U @ U), dtype=float)


def _desired(desired: ArrayLike | None, variant: str, needs: bool) -> FloatArray | None:
    if desired is None:
        if needs:
            raise ConfigurationError(
                f"the {variant!r} pose feature needs desired (c*Mo, the object's pose in the "
                "desired camera frame, 4x4)"
            )
        return None
    return as_transform(desired, "desired")


class PoseTranslation(Feature):
    """A translation feature (module docstring), ``s = (tx, ty, tz)`` in metres.

    Args:
        variant: ``"cdMc"``, ``"cMo"`` or ``"cMcd"``.
        desired: ``c*Mo`` (4x4), needed by ``cdMc`` and ``cMcd``.

    Raises:
        ConfigurationError: an unknown variant, or no ``desired`` where it is needed.
    """

    names = ("tx", "ty", "tz")
    angular = (False, False, False)

    def __init__(self, variant: TranslationVariant = "cdMc", desired: ArrayLike | None = None):
        if variant not in TRANSLATION_VARIANTS:
            raise ConfigurationError(
                f"translation variant must be one of {', '.join(TRANSLATION_VARIANTS)}, "
                f"got {variant!r}"
            )
        self.variant: TranslationVariant = variant
        self.desired = _desired(desired, variant, variant != "cMo")
        self._oMcd = None if self.desired is None else inverse(self.desired)

    def measure(self, cMo: FloatArray) -> Measurement:
        T = as_transform(cMo, "cMo")
        if self.variant == "cMo":
            return Measurement(T[:3, 3].copy(), _EMPTY)
        assert self.desired is not None and self._oMcd is not None
        if self.variant == "cMcd":
            return Measurement((T @ self._oMcd)[:3, 3].copy(), _EMPTY)
        cdMc = self.desired @ inverse(T)
        tu = matrix_to_rotvec(cdMc[:3, :3])
        return Measurement(cdMc[:3, 3].copy(), np.array([*tu, 1.0]))

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        t = as_vector(s, "s", 3)
        L = np.zeros((3, 6))
        if self.variant == "cdMc":
            p = as_vector(inv_depth, "inv_depth", 4)
            L[:, :3] = rotvec_to_matrix(p[:3] / p[3])
        else:
            L[:, :3] = -np.eye(3)
            L[:, 3:] = skew(t)
        return L

    def __repr__(self) -> str:
        return f"PoseTranslation(variant={self.variant!r})"


class PoseThetaU(Feature):
    """A rotation feature ``s = θu`` (rad) of ``c*R_c`` or ``c R_c*`` (module docstring).

    Args:
        variant: ``"cdRc"`` or ``"cRcd"``.
        desired: ``c*Mo`` (4x4).

    Raises:
        ConfigurationError: an unknown variant or no ``desired``.
    """

    names = ("tux", "tuy", "tuz")
    angular = (False, False, False)

    def __init__(self, variant: RotationVariant = "cdRc", desired: ArrayLike | None = None):
        if variant not in ROTATION_VARIANTS:
            raise ConfigurationError(
                f"rotation variant must be one of {', '.join(ROTATION_VARIANTS)}, got {variant!r}"
            )
        self.variant: RotationVariant = variant
        d = _desired(desired, variant, True)
        assert d is not None
        self.desired = d

    def measure(self, cMo: FloatArray) -> Measurement:
        T = as_transform(cMo, "cMo")
        cdRc = self.desired[:3, :3] @ T[:3, :3].T
        R = cdRc if self.variant == "cdRc" else cdRc.T
        return Measurement(matrix_to_rotvec(R), _EMPTY)

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        tu = as_vector(s, "s", 3)
        L = np.zeros((3, 6))
        if self.variant == "cdRc":
            L[:, 3:] = thetau_interaction(tu)
        else:
            L[:, 3:] = -thetau_interaction(-tu)
        return L

    def __repr__(self) -> str:
        return f"PoseThetaU(variant={self.variant!r})"


class LogDepth(Feature):
    """``s = log Z`` (Z in metres) of a point fixed in the object frame: with ``s* = log Z*`` the
    error is ``log(Z/Z*)``, the depth component of the 2½-D task (Malis, Chaumette & Boudet 1999;
    with a point ``(x, y)`` and ``θu`` of ``c*R_c``).

    ``L = [0, 0, -1/Z, -y, x, 0]`` (from ``Ż = -v_z - ω_x Y + ω_y X``). Parameters
    ``(1/Z, x/Z, y/Z)``: ``L`` uses ``1/Z`` and ``x, y`` as their ratios, so a depth-estimate factor
    scales only the ``1/Z`` term.

    Args:
        point_o: (3,) the point in the object frame (m).
    """

    names = ("log_z",)
    angular = (False,)

    def __init__(self, point_o: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        self.point_o = as_vector(point_o, "point_o", 3)

    def measure(self, cMo: FloatArray) -> Measurement:
        from redservo.features.point import project_point

        T = as_transform(cMo, "cMo")
        X = T[:3, :3] @ self.point_o + T[:3, 3]
        x, y, inv_z = project_point(X)  # raises GeometryError behind the camera
        return Measurement(np.array([np.log(X[2])]), np.array([inv_z, x * inv_z, y * inv_z]))

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        as_vector(s, "s", 1)
        p = as_vector(inv_depth, "inv_depth", 3)
        x, y = p[1] / p[0], p[2] / p[0]
        return np.array([[0.0, 0.0, -p[0], -y, x, 0.0]])

    def __repr__(self) -> str:
        return f"LogDepth(point_o={self.point_o.tolist()})"


TRANSLATION_KIND = FeatureKind(
    "pose_translation", PoseTranslation, schema="redservo.schema.features:PoseTranslationSpec"
)
"""The translation of a pose (no scene object of its own; :mod:`redservo.features.kinds`)."""
THETAU_KIND = FeatureKind(
    "pose_thetau", PoseThetaU, schema="redservo.schema.features:PoseThetaUSpec"
)
"""The rotation of a pose (no scene object of its own)."""
LOG_DEPTH_KIND = FeatureKind(
    "log_depth",
    LogDepth,
    schema="redservo.schema.features:LogDepthSpec",
    obj="redservo.scene:PointSet",
)
"""The log-depth of a point; it observes point sets, drawn by the point kind."""
