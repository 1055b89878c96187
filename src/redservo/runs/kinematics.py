"""The robot's kinematics along a run, logged into its directory (``kinematics.npz``), and a
robot that replays them, so that a saved run is shown and plotted without the robot's model
(a URDF robot without Pinocchio, or a model whose code has changed).

:func:`write_kinematics` evaluates, at every logged configuration ``q[k]``, the camera pose
``bMc`` (4x4, m), the task Jacobian ``J(q)`` (6 x n, ``v_c = J q̇`` in the camera frame) and,
when the robot has ``link_poses``, the pose of each link in the base frame (4x4, m); it
also stores the joint names and types and the limits the run used. :class:`LoggedRobot`
is a :class:`~redservo.robots.base.Robot` that answers ``fkine``, ``jacobian`` and
``link_poses`` at those configurations only (bit for bit what the run's robot gave);
anywhere else it raises a :class:`~redservo.errors.ConfigurationError`: it can show a
run, never simulate a new one. :meth:`redservo.runs.load.Run.experiment` falls back to it when
the run's own robot cannot be built.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_vector
from redservo.errors import ConfigurationError
from redservo.robots.base import Robot

__all__ = ["KINEMATICS_FILE", "LoggedRobot", "write_kinematics"]

KINEMATICS_FILE = "kinematics.npz"
"""The file, in a run directory, that :func:`write_kinematics` writes."""


def _limit(value: Any) -> FloatArray:
    return np.full(0, np.nan) if value is None else np.asarray(value, dtype=float)


def write_kinematics(out: Path, robot: Robot, q: FloatArray) -> Path:
    """Write ``out/kinematics.npz``: the robot's kinematics at each row of ``q`` (N, n).

    Keys: ``q`` (N, n), ``bMc`` (N, 4, 4), ``jacobian`` (N, 6, n), ``links`` (N, L, 4, 4)
    and ``link_names`` (L,) (L = 0 when the robot has no ``link_poses``), ``joint_names``,
    ``joint_types``, ``name``, and the limits ``q_min``, ``q_max``, ``qdot_max``,
    ``qddot_max`` (empty when the robot has none). Units: m, rad, s.
    """
    q = np.asarray(q, dtype=float).reshape(-1, robot.n)
    N = q.shape[0]
    bMc = np.empty((N, 4, 4))
    jac = np.empty((N, 6, robot.n))
    link_poses = getattr(robot, "link_poses", None)
    names: list[str] = []
    links = np.empty((N, 0, 4, 4))
    for k in range(N):
        bMc[k], jac[k] = robot.kinematics(q[k], check_limits=False)
        if link_poses is not None:
            poses = link_poses(q[k], check_limits=False)
            if k == 0:
                names = list(poses)
                links = np.empty((N, len(names), 4, 4))
            links[k] = np.stack([poses[n] for n in names]) if names else links[k]
    path = out / KINEMATICS_FILE
    np.savez_compressed(
        path,
        q=q,
        bMc=bMc,
        jacobian=jac,
        links=links,
        link_names=np.array(names, dtype=str),
        joint_names=np.array(robot.joint_names, dtype=str),
        joint_types=np.array(robot.joint_types, dtype=str),
        name=np.array(robot.name),
        q_min=robot.q_min,
        q_max=robot.q_max,
        qdot_max=_limit(robot.qdot_max),
        qddot_max=_limit(robot.qddot_max),
    )
    return path


class LoggedRobot(Robot):
    """A robot that replays a run's logged kinematics (module docstring).

    Args:
        path: A run directory's ``kinematics.npz``.

    Raises:
        ConfigurationError: the file is missing or damaged.
    """

    def __init__(self, path: str | Path) -> None:
        p = Path(path)
        try:
            with np.load(p, allow_pickle=False) as z:
                data = {k: np.asarray(z[k]) for k in z.files}
        except (OSError, ValueError) as exc:
            raise ConfigurationError(f"{p}: cannot read the logged kinematics ({exc})") from None
        qdot, qddot = data["qdot_max"], data["qddot_max"]
        super().__init__(
            name=f"{data['name']} (logged)",
            joint_names=[str(s) for s in data["joint_names"]],
            joint_types=[str(s) for s in data["joint_types"]],  # type: ignore[misc]
            q_min=data["q_min"],
            q_max=data["q_max"],
            qdot_max=qdot if qdot.size else None,
            qddot_max=qddot if qddot.size else None,
        )
        self.path = p
        self._q = data["q"]
        self._bMc = data["bMc"]
        self._J = data["jacobian"]
        self._links = data["links"]
        self.link_names = tuple(str(s) for s in data["link_names"])
        self._row = {self._q[k].tobytes(): k for k in range(self._q.shape[0])}

    def _index(self, q: ArrayLike) -> int:
        qa = as_vector(q, "q", self.n)
        k = self._row.get(np.ascontiguousarray(qa, dtype=float).tobytes())
        if k is None:
            raise ConfigurationError(
                f"{self.path}: the kinematics are logged only at the run's own configurations "
                f"(q = {np.array2string(qa, precision=4)} is not one of them); build the run's "
                "robot to compute others (for a URDF robot: pip install 'redservo[urdf]')",
                argument="q",
            )
        return k

    def fkine(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """The logged camera pose ``bMc`` (4x4, m) at a logged ``q``."""
        return np.array(self._bMc[self._index(q)])

    def jacobian(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """The logged ``J(q)`` (6, n) at a logged ``q`` (``v_c = J q̇``, camera frame)."""
        return np.array(self._J[self._index(q)])

    def kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """``(fkine(q), jacobian(q))`` at a logged ``q``."""
        k = self._index(q)
        return np.array(self._bMc[k]), np.array(self._J[k])

    def link_poses(self, q: ArrayLike, *, check_limits: bool = True) -> dict[str, FloatArray]:
        """The logged ``{link name: bMl}`` (4x4, m) at a logged ``q``, base to tip."""
        k = self._index(q)
        return {name: np.array(self._links[k, i]) for i, name in enumerate(self.link_names)}

    def ikine(
        self,
        bMc: ArrayLike,
        q0: ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        max_iterations: int = 500,
    ) -> FloatArray:
        """The run's start ``q[0]`` when ``bMc`` is its logged start pose (within 1e-6)."""
        target = np.asarray(bMc, dtype=float)
        if not np.allclose(target, self._bMc[0], atol=1e-6):
            raise ConfigurationError(
                f"{self.path}: the logged kinematics reach only the run's own start pose",
                argument="bMc",
            )
        return np.array(self._q[0])

    def fkine_ee(self, q: FloatArray) -> FloatArray:
        """Not available: the logged camera pose is :meth:`fkine` (the hand-eye folded in)."""
        raise ConfigurationError("a LoggedRobot replays bMc only (fkine)", argument="q")

    def jacobe(self, q: FloatArray) -> FloatArray:
        """Not available: the logged Jacobian is :meth:`jacobian` (the hand-eye folded in)."""
        raise ConfigurationError("a LoggedRobot replays J only (jacobian)", argument="q")
