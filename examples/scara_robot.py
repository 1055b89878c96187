"""A new robot kind in one file: a SCARA arm, compiled into the step kernel.

A 4-joint SCARA (two revolute joints about the vertical, a prismatic quill, a revolute
wrist) with a camera looking down from its tool: the camera pose is
``bMe = Tz(h) Rz(θ1) Tx(a1) Rz(θ2) Tx(a2) Tz(-d3) Rz(θ4) Rx(π)``, ``bMc = bMe eMc``, and its
Jacobian ``J = cVe eJe`` (docs/formulas.md §1). Everything a robot kind needs is below: its
kinematics kernel (a :func:`~redservo.kernels._jit.kernel` with the kind signature
``(q, eMc, cVe, scalars, table, frames) -> (bMc, J)``), its declaration (``KIND =
RobotKind(...)``, which gives it the next kind code of the compiled dispatch) and its
``kernel_pack``; one line (:func:`~redservo.robots.register_robot`) makes it the model
``"scara"`` of a scenario. The kind is declared at import, before the first compiled step
of the process (docs/extending.md, "Add a robot kind").

    python examples/scara_robot.py [--samples N] [--quick]
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

import redservo
from redservo._validation import FloatArray
from redservo.kernels._jit import kernel
from redservo.kernels.kinematics import matmul
from redservo.records import outcome_text
from redservo.robots import Robot, register_robot
from redservo.robots.pack import RobotKind, RobotPack


@kernel
def scara_kinematics(q: Any, eMc: Any, cVe: Any, scalars: Any, table: Any, frames: Any) -> Any:
    """``(bMc, J)`` of the SCARA (module docstring): the camera pose (4, 4; m) and
    ``J = cVe eJe`` (6, 4) at ``q = (θ1, θ2, d3, θ4)`` (rad, rad, m, rad); ``scalars`` is
    ``(h, a1, a2)`` (m): the height of the first axis and the two link lengths."""
    h, a1, a2 = scalars[0], scalars[1], scalars[2]
    c1, s1 = math.cos(q[0]), math.sin(q[0])
    c12, s12 = math.cos(q[0] + q[1]), math.sin(q[0] + q[1])
    phi = q[0] + q[1] + q[3]
    cp, sp = math.cos(phi), math.sin(phi)
    bMe = np.zeros((4, 4))
    # R = Rz(φ) Rx(π): the tool's z axis points down
    bMe[0, 0], bMe[0, 1] = cp, sp
    bMe[1, 0], bMe[1, 1] = sp, -cp
    bMe[2, 2] = -1.0
    bMe[0, 3] = a1 * c1 + a2 * c12
    bMe[1, 3] = a1 * s1 + a2 * s12
    bMe[2, 3] = h - q[2]
    bMe[3, 3] = 1.0
    # base-frame Jacobian (v; ω) of the tool origin, then expressed in the tool frame
    bJ = np.zeros((6, 4))
    bJ[0, 0], bJ[1, 0] = -bMe[1, 3], bMe[0, 3]
    bJ[0, 1], bJ[1, 1] = -a2 * s12, a2 * c12
    bJ[2, 2] = -1.0
    bJ[5, 0] = bJ[5, 1] = bJ[5, 3] = 1.0
    eJe = np.zeros((6, 4))
    for j in range(4):
        for r in range(3):
            for k in range(3):
                eJe[r, j] += bMe[k, r] * bJ[k, j]
                eJe[r + 3, j] += bMe[k, r] * bJ[k + 3, j]
    return matmul(bMe, eMc), matmul(cVe, eJe)


class Scara(Robot):
    """A 4-joint SCARA with a downward camera (module docstring).

    Args:
        h: Height of the first joint axis above the base (m).
        a1, a2: Link lengths (m).
        eMc: Hand-eye transform (4, 4; m), identity by default.
    """

    KIND = RobotKind("scara", f"{__name__}:scara_kinematics")

    def __init__(
        self, *, h: float = 0.8, a1: float = 0.4, a2: float = 0.3, eMc: ArrayLike | None = None
    ) -> None:
        self._lengths = (float(h), float(a1), float(a2))
        super().__init__(
            name="scara",
            joint_names=("theta1", "theta2", "d3", "theta4"),
            joint_types=("revolute", "revolute", "prismatic", "revolute"),
            q_min=[-2.0, -2.2, 0.0, -3.0],
            q_max=[2.0, 2.2, 0.3, 3.0],
            eMc=eMc,
            qdot_max=[1.5, 1.5, 0.3, 2.0],
        )

    def _kernel(self, q: ArrayLike, eMc: FloatArray, cVe: FloatArray) -> tuple[Any, Any]:
        """The kernel at the validated ``q``, with the parts of the pack (same types)."""
        qa = np.ascontiguousarray(q, dtype=np.float64)
        lengths = np.array(self._lengths)
        out: tuple[Any, Any] = scara_kinematics(
            qa, eMc, cVe, lengths, np.zeros((0, 0)), np.zeros((0, 0, 0))
        )
        return out

    def fkine_ee(self, q: FloatArray) -> FloatArray:
        return np.asarray(self._kernel(q, np.eye(4), np.eye(6))[0])

    def jacobe(self, q: FloatArray) -> FloatArray:
        return np.asarray(self._kernel(q, np.eye(4), np.eye(6))[1])

    def kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """``(bMc, J)`` in one kernel call: the numbers of the compiled engine, bit for bit."""
        qa = self.check_q(q, check_limits=check_limits)
        bMc, J = self._kernel(qa, self.eMc, self.cVe)
        return np.asarray(bMc), np.asarray(J)

    def fkine(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        return self.kinematics(q, check_limits=check_limits)[0]

    def jacobian(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        return self.kinematics(q, check_limits=check_limits)[1]

    def kernel_pack(self) -> RobotPack | None:
        """The SCARA as the compiled engine takes it (:mod:`redservo.robots.pack`)."""
        return self.KIND.pack(self.eMc, self.cVe, scalars=self._lengths)


register_robot("scara", Scara)

SCENARIO = """\
name = "scara-gaze"
description = "a SCARA gazing down at a point (m = 2, n = 4)"

[robot]
model = "scara"
q0 = [0.3, 1.2, 0.1, 0.0]   # rad, rad, m, rad
rho = 0.1

[[objects]]
name = "target"
kind = "points"
points = [[0.0, 0.0, 0.0]]
pose_in_camera = { translation = [0.08, -0.05, 0.6] }   # m, start camera axes

[[features]]
kind = "point"
object = "target"

[task]
desired = [0.0, 0.0]

[control]
method = "gpm"
lam = 1.0
dt = 0.04

[simulation]
max_iterations = 150
tolerance = 1e-3

[sensor]
kind = "ideal"
depth = "true"
"""

CAMPAIGN = """\
name = "scara-gaze"
description = "a SCARA gazing at a point from random starts near its limits"
scenario = "scara-gaze.toml"
samples = 8
methods = ["classical", "gpm"]

[start]
p_band = 0.5
band_beyond = 0.5
min_margin = 0.01
min_in_band = 1

[target]
translation = [0.08, 0.08, [-0.1, 0.1]]   # m, start camera axes
rotation_deg = [0, 0, 0]
image_margin_px = 20
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=8, help="campaign samples (default 8)")
    parser.add_argument("--quick", action="store_true", help="short runs (tests)")
    args = parser.parse_args(argv)
    print(f"kind: {Scara.KIND.name} code {Scara.KIND.code}")
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "scara-gaze.toml").write_text(SCENARIO, encoding="utf-8")
        (Path(tmp) / "campaign.toml").write_text(CAMPAIGN, encoding="utf-8")
        r = redservo.run(str(Path(tmp) / "scara-gaze.toml"))
        print(f"simulate: {outcome_text(r.summary)}, engine {r.engine}")
        res = redservo.campaign(
            str(Path(tmp) / "campaign.toml"), samples=2 if args.quick else args.samples
        )
    for method, st in res.stats.items():
        print(f"campaign: {method:10s} success {st.successes}/{st.runs}")
    print(*(line for line in res.markdown.splitlines() if line.startswith("Engine:")))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
