"""The 9-DOF virtual humanoid torso of CM01 §V-B: pelvis 3, spine 1, neck 3, eyes 2.

CM01 says only that the torso has "pelvis (3 d.o.f), spine (1 d.o.f), neck
(3 d.o.f), eyes (2 d.o.f)" and that it was modelled with Denavit–Hartenberg
parameters; it gives no numbers. Everything below is our choice, made to be
anatomically plausible (docs/formulas.md §11.4 records the paper's statement).

Frames. The base frame is on the floor, midway between the feet: x forward,
y to the person's left, z up. ``eMc`` maps the last DH frame (x along the gaze)
to a camera frame with ``z_c`` = gaze, ``x_c`` = image right, ``y_c`` = image down.
At ``q = 0`` (= :meth:`Humanoid9.rest_configuration`) the person stands upright
and the gaze is horizontal, straight ahead (+x of the base).

Joints (standard DH; all revolute; see ``Humanoid9.DH_TABLE``) and sign
conventions: the pelvis rotates the trunk over the legs about three axes
through the hip-joint centre, in the order yaw (about the vertical; positive =
turn left), roll (about the forward axis; positive = lean right) and pitch
(about the lateral axis; positive = bend forward). The spine has one pitch
joint (positive = bend forward). The neck has pitch (positive = chin down),
roll (positive = tilt right), yaw (positive = turn left), all three at the base
of the neck. The eyes are a single cyclopean eye with a Fick gimbal: pan
(positive = look left), then tilt (positive = look down). Middle joints of each
3-DOF group are roll joints whose range stays far from the ±90° gimbal lock.

Segment lengths (``stature`` H, default 1.75 m, about the 50th-percentile
adult male of NASA-STD-3000 / MSIS Vol. I §3.3.1) follow the segment-length
proportions of Drillis & Contini (1966) reproduced in Winter, "Biomechanics and
Motor Control of Human Movement", 4th ed., Fig. 4.1: hip (greater trochanter)
0.530 H, shoulder 0.818 H, eyes 0.936 H above the floor. The spine joint is
placed midway between hip and shoulder height (0.144 H above the hips), the
neck base at shoulder height (another 0.144 H), the eyes 0.118 H above the neck
base and ``EYE_FORWARD = 0.09`` m in front of it (about half the head length,
≈ 0.19–0.20 m in MSIS/ANSUR; our estimate).

Joint ranges (deg), from the average active ranges of motion of the AAOS
("Joint Motion: Method of Measuring and Recording", 1965; Greene & Heckman,
"The Clinical Measurement of Joint Motion", AAOS 1994), trimmed to stay
conservative:

* pelvis (trunk over the legs, hip + lumbar motion): yaw ±70 (hip rotation
  ≈ 45 plus thoraco-lumbar rotation ≈ 45), roll ±50 (hip ab/adduction 30–45
  plus thoraco-lumbar lateral bending 35), pitch −30 (extension, hip 30) to +90
  (flexion with straight knees);
* spine pitch: −25 (thoraco-lumbar extension 25) to +60 (share of the 80 of
  flexion not already taken by the pelvis);
* neck: pitch −45/+45 (cervical extension/flexion 45), roll ±45 (lateral
  bending 45), yaw ±60 (rotation 60);
* eyes: pan ±15, tilt ±15. The oculomotor range is about ±45–50, but humans
  rarely rotate the eyes more than about 15 before the head follows (Bahill,
  Adler & Stark, "Most naturally occurring human saccades have magnitudes of
  15 degrees or less", Invest. Ophthalmol. 14(6), 1975; MIL-STD-1472 and
  NASA-STD-3000 use ±15 as the easy eye rotation).

So the eye ranges are far smaller than the neck ranges, which are smaller than
the corresponding pelvis ranges (yaw 120 < 140, roll 90 < 100, pitch 90 < 120
degrees of travel): in a tracking task the eyes saturate first, then the neck,
then the pelvis, which lets CM01's eye → neck → pelvis motion transfer appear.
"""

from __future__ import annotations

import math
from typing import ClassVar, Final

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.robots.dh import DHLink, DHRobot
from redservo.spatial import make_transform

__all__ = ["JOINT_GROUPS", "Humanoid9"]

JOINT_GROUPS: Final[dict[str, tuple[int, ...]]] = {
    "pelvis": (0, 1, 2),
    "spine": (3,),
    "neck": (4, 5, 6),
    "eyes": (7, 8),
}
"""Indices of the joints of each body part, base to tip."""

HIP_HEIGHT: Final = 0.530
"""Hip-joint height as a fraction of stature (Winter Fig. 4.1)."""
SHOULDER_HEIGHT: Final = 0.818
"""Shoulder (neck base) height as a fraction of stature (Winter Fig. 4.1)."""
EYE_HEIGHT: Final = 0.936
"""Eye height as a fraction of stature (Winter Fig. 4.1)."""
EYE_FORWARD: Final = 0.09
"""Horizontal distance (m) from the neck axis to the eyes."""

_H2 = math.pi / 2
#: ``eMc``: the camera z axis along the last DH frame's x (the gaze), x_c = -z_9 (right).
HUMANOID_QDOT_MAX: Final = (1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 6.0, 6.0)
"""Velocity limits (rad/s). A documented choice (CM01's humanoid is virtual): torso joints
1 rad/s, neck 2 rad/s, eyes 6 rad/s (human smooth pursuit reaches about 1-1.7 rad/s and
saccades far more; actuated eyes of humanoid heads are rated several rad/s)."""
HUMANOID_QDDOT_MAX: Final = (5.0, 5.0, 5.0, 5.0, 10.0, 10.0, 10.0, 50.0, 50.0)
"""Acceleration limits (rad/s²), a documented choice in the same spirit."""
_E_M_C: Final = make_transform(R=[[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])


def humanoid_links(stature: float = 1.75) -> tuple[DHLink, ...]:
    """Return the standard-DH rows of the torso for a person of height ``stature`` (m).

    The rows, base to tip (lengths in m for H = ``stature``; angles in rad)::

        joint         a                 alpha   d                  offset  range (deg)
        pelvis_yaw    0                 +π/2    0                  +π/2    -70 .. 70
        pelvis_roll   0                 +π/2    0                  +π/2    -50 .. 50
        pelvis_pitch  0.144 H (spine)   0       0                  0       -30 .. 90
        spine_pitch   0.144 H (spine)   0       0                  0       -25 .. 60
        neck_pitch    0                 -π/2    0                  0       -45 .. 45
        neck_roll     0                 -π/2    0                  -π/2    -45 .. 45
        neck_yaw      0.09 H/1.75 (fwd) 0       0.118 H (head)     -π/2    -60 .. 60
        eye_pan       0                 -π/2    0                  0       -15 .. 15
        eye_tilt      0                 0       0                  0       -15 .. 15
    """
    spine = 0.5 * (SHOULDER_HEIGHT - HIP_HEIGHT) * stature
    head = (EYE_HEIGHT - SHOULDER_HEIGHT) * stature
    forward = EYE_FORWARD * stature / 1.75
    r = math.radians
    return (
        DHLink(alpha=_H2, offset=_H2, q_min=r(-70), q_max=r(70), name="pelvis_yaw"),
        DHLink(alpha=_H2, offset=_H2, q_min=r(-50), q_max=r(50), name="pelvis_roll"),
        DHLink(a=spine, q_min=r(-30), q_max=r(90), name="pelvis_pitch"),
        DHLink(a=spine, q_min=r(-25), q_max=r(60), name="spine_pitch"),
        DHLink(alpha=-_H2, q_min=r(-45), q_max=r(45), name="neck_pitch"),
        DHLink(alpha=-_H2, offset=-_H2, q_min=r(-45), q_max=r(45), name="neck_roll"),
        DHLink(a=forward, d=head, offset=-_H2, q_min=r(-60), q_max=r(60), name="neck_yaw"),
        DHLink(alpha=-_H2, q_min=r(-15), q_max=r(15), name="eye_pan"),
        DHLink(q_min=r(-15), q_max=r(15), name="eye_tilt"),
    )


class Humanoid9(DHRobot):
    """CM01's 9-DOF humanoid torso (pelvis 3, spine 1, neck 3, eyes 2), camera at the eyes.

    Args:
        stature: Body height H (m) that scales the segment lengths (default 1.75).
        eMc: 4x4 camera pose in the last DH frame (default: z_c along the gaze,
            x_c to the right, at the eye centre).

    See the module docstring for the frames, sign conventions, lengths, ranges
    and their sources.
    """

    JOINT_GROUPS: ClassVar[dict[str, tuple[int, ...]]] = JOINT_GROUPS

    def __init__(self, *, stature: float = 1.75, eMc: ArrayLike | None = None) -> None:
        if not (isinstance(stature, int | float) and 0.5 <= float(stature) <= 2.5):
            raise ConfigurationError(f"stature must be a height in [0.5, 2.5] m, got {stature!r}")
        self.stature = float(stature)
        super().__init__(
            humanoid_links(self.stature),
            convention="standard",
            base=make_transform(t=(0.0, 0.0, HIP_HEIGHT * self.stature)),
            eMc=_E_M_C.copy() if eMc is None else eMc,
            name="humanoid9",
            qdot_max=HUMANOID_QDOT_MAX,
            qddot_max=HUMANOID_QDDOT_MAX,
        )

    @staticmethod
    def rest_configuration() -> FloatArray:
        """Return the rest posture (9,): upright, gaze horizontal and straight ahead (all zeros)."""
        return np.zeros(9)
