"""Eye-to-hand: a camera fixed in the world observing a target the robot carries.

:class:`EyeToHandRobot` wraps any :class:`~redservo.robots.base.Robot` so that everything
built for an eye-in-hand camera (scene, task, features, image sensor, every law) runs
unchanged. It describes the set-up *from the carried target's side*: its "base" frame is
the robot's end-effector frame ``e`` (where the target is fixed, ``eMo`` constant), its
"camera pose" is where the fixed camera is seen from there::

    fkine(q) = eMc(q) = inv(bMe(q)) · bMc          (bMc: the fixed camera in the base frame)

so ``cMo(q) = inv(eMc(q)) · eMo = cMb · bMe(q) · eMo``, the true relative pose.

**Task Jacobian** (ViSP's ``EYETOHAND_L_cVe_eJe``). The target moves with the effector:
a point ``X`` of it has, in the camera frame, ``Ẋ = v_e^c + ω_e^c × (X − t)`` with
``(v_e^c, ω_e^c) = (cRe v_e, cRe ω_e)``, ``(v_e, ω_e) = eJe(q) q̇`` the effector twist in
its own frame, and ``t = c t_e`` the effector origin in the camera frame. An eye-in-hand
camera of twist ``v_c = (v, ω)`` sees a still point move as ``Ẋ = −v − ω × X``. Equating
for every ``X``: ``ω = −ω_e^c`` and ``v = −v_e^c − t × ω_e^c``, i.e.::

    v_c = −cVe(q) · eJe(q) · q̇,    cVe(q) = [[cRe, [c t_e]× cRe], [0, cRe]],  cMe = cMb · bMe(q)

so ``ṡ = L_s · v_c = −L_s · cVe(q) · eJe(q) · q̇`` and ``J1 = −C · L_s · cVe(q) · eJe(q)``:
the same form as eye-in-hand with the sign changed and ``cVe`` now depending on ``q``
(``tests/test_eye_to_hand.py`` checks it by finite differences of ``s(q)`` for every
feature kind). :meth:`jacobe` returns ``−cVe(q) eJe(q)``, and the wrapper's own ``eMc``
is the identity, so :meth:`jacobian` is that matrix.

The compiled kernels (:mod:`redservo.binding`, the campaign loop) know only the
eye-in-hand kinematics of their robot classes; they reject this class by its type
("no compiled kinematics"), and the Python controller runs it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform
from redservo.robots.base import Robot
from redservo.spatial import inverse, twist_transform

__all__ = ["EyeToHandRobot"]


class EyeToHandRobot(Robot):
    """A robot carrying the target in front of a camera fixed in its base frame.

    Args:
        robot: The robot that carries the target; its ``fkine_ee``/``jacobe`` (the
            end-effector, for a URDF robot its ``camera_link``) are used, its ``eMc`` is not.
        bMc: 4x4 pose of the fixed camera in the robot's base frame (the world frame of
            a scenario).
    """

    def __init__(self, robot: Robot, bMc: ArrayLike) -> None:
        lim = robot.limits()
        super().__init__(
            name=f"{robot.name} (eye-to-hand)",
            joint_names=robot.joint_names,
            joint_types=robot.joint_types,
            q_min=lim.q_min,
            q_max=lim.q_max,
            qdot_max=lim.qdot_max,
            qddot_max=lim.qddot_max,
        )
        self.carrier = robot
        self.bMc = as_transform(bMc, "bMc")

    def fkine_ee(self, q: FloatArray) -> FloatArray:
        """``eMc(q) = inv(bMe(q)) · bMc`` (4x4): the fixed camera seen from the effector."""
        return np.asarray(inverse(self.carrier.fkine_ee(q)) @ self.bMc, dtype=float)

    def jacobe(self, q: FloatArray) -> FloatArray:
        """``−cVe(q) · eJe(q)`` (6, n): the camera twist relative to the target (module
        docstring), in the camera frame."""
        return self._jacobian(inverse(self.fkine_ee(q)), q)

    def _jacobian(self, cMe: FloatArray, q: FloatArray) -> FloatArray:
        return np.asarray(-(twist_transform(cMe) @ self.carrier.jacobe(q)), dtype=float)

    def kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """``(eMc(q), −cVe(q) eJe(q))`` with one forward kinematics."""
        qa = self.check_q(q, check_limits=check_limits)
        cMe = inverse(self.bMc) @ self.carrier.fkine_ee(qa)
        return inverse(cMe), self._jacobian(cMe, qa)
