"""Drive ViSP's step (the optional harness ``visp_step``, built by ``build.sh``) from Python.

:class:`VispStep` starts the harness as a child process, gives it the ``afma6-4points`` case
of :mod:`redservo.bench.cases` (the joints ``q``, the poses ``cMo`` and ``cdMo``, the square's
points, ``λ`` and the Afma6's ``eMc``) and then times ViSP's ``vpServo`` step in batches, on
request, so that a benchmark interleaves it with its own items in the same rounds
(``benchmarks/bench_object_path.py --visp PATH``). :func:`agreement` compares ViSP's numbers
with redservo's on the same inputs. ViSP is GPL: the harness is a separate program that
only calls ViSP's public API; nothing of redservo links or imports it (visp_step.cpp's
header). Units: µs per step, m, rad, s; features in normalized image units.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["HarnessError", "VispStep", "agreement", "setup_line"]

ONE_THREAD = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""ViSP's OpenMP and BLAS on one thread, as redservo's kernels (a fair single-thread step)."""


class HarnessError(RuntimeError):
    """The harness is missing, not executable, or answered off its protocol (the message
    names the path and the line)."""


def _numbers(*arrays: Any) -> str:
    return " ".join(repr(float(x)) for a in arrays for x in np.asarray(a, dtype=float).ravel())


def setup_line(case: Any) -> str:
    """The harness's ``setup`` line for a bench case of 4 static points (``afma6-4points``):
    ``q``, ``cMo`` (from the robot's ``bMc`` at ``q`` and the target's pose), ``cdMo`` (the
    pose the task's ``s*`` was computed at), the points (m), ``λ`` (1/s) and ``eMc``."""
    from redservo.bench.cases import SQUARE

    robot, q = case.robot, case.q
    bMc, _ = robot.kinematics(q)
    cMo = case.scene.cMo("t", bMc, 0.0)
    cdMo = desired_pose(case)
    return "setup " + _numbers(q, cMo, cdMo, SQUARE, [case.lam], robot.eMc)


def desired_pose(case: Any) -> Any:
    """``cdMo`` of the ``afma6-4points`` case (4x4): the target 0.6 m ahead on the axis."""
    from redservo.spatial import make_transform

    return make_transform(t=(0.0, 0.0, 0.6))


class VispStep:
    """The running harness (module docstring); ``close()`` ends it.

    Args:
        path: The ``visp_step`` executable.
        case: The bench case (``afma6-4points``).

    Raises:
        HarnessError: ``path`` is not an executable file, or the harness refused the case.
    """

    def __init__(self, path: Path, case: Any) -> None:
        path = Path(path)
        if not (path.is_file() and os.access(path, os.X_OK)):
            raise HarnessError(
                f"--visp {path}: not an executable file (build it: sh benchmarks/visp/build.sh)"
            )
        self.path = path
        self._proc = subprocess.Popen(
            [str(path)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env={**os.environ, **ONE_THREAD},
        )
        try:
            self.version = self._ask("version")
            self._ask(setup_line(case), expect="ok")
        except HarnessError:
            self.close(kill=True)
            raise

    def _ask(self, line: str | None, expect: str | None = None) -> str:
        """Send ``line`` (None: none) and read one answer line."""
        proc = self._proc
        assert proc.stdin is not None and proc.stdout is not None
        try:
            if line is not None:
                proc.stdin.write(line + "\n")
                proc.stdin.flush()
            answer = proc.stdout.readline().strip()
        except (BrokenPipeError, OSError) as err:
            raise HarnessError(f"{self.path}: the harness ended ({err})") from err
        if not answer or answer.startswith("error") or (expect and answer != expect):
            asked = "its previous command" if line is None else repr(line.split()[0])
            raise HarnessError(f"{self.path}: answered {answer!r} to {asked}")
        return answer

    def per_call_us(self, batch: int, cpu: bool) -> float:
        """ViSP's step timed over ``batch`` steps inside the harness: µs per step, of the
        harness thread's CPU time (``cpu``) or of the wall clock."""
        cpu_ns, wall_ns = (int(x) for x in self._ask(f"time {int(batch)}").split())
        return (cpu_ns if cpu else wall_ns) / batch / 1e3

    def check(self) -> dict[str, Any]:
        """ViSP's numbers at the case's state: ``qdot`` (6,) (rad/s or m/s), ``e`` (8,),
        ``L`` (8, 6) and ``J`` = cVe eJe (6, 6)."""
        shapes = {"qdot": (6,), "e": (8,), "L": (8, 6), "J": (6, 6)}
        out: dict[str, Any] = {}
        line = self._ask("check")
        while line != "end":
            name, *values = line.split()
            out[name] = np.array([float(v) for v in values]).reshape(shapes[name])
            line = self._ask(None)
        return out

    def close(self, kill: bool = False) -> None:
        """End the harness: its stdin closed (it returns), or (``kill``) killed."""
        proc = self._proc
        if kill:
            proc.kill()
        if proc.stdin is not None:
            try:
                proc.stdin.close()
            except BrokenPipeError:
                pass
        proc.wait(timeout=10)
        if proc.stdout is not None:
            proc.stdout.close()


def agreement(case: Any, visp: dict[str, Any]) -> dict[str, float]:
    """Largest absolute differences between ViSP's numbers and redservo's at the case's
    state: the robot Jacobian ``J``, the interaction matrix ``L`` and the error ``e`` (8
    point coordinates), and the classical law's ``q̇`` on ViSP's own ``J1 = L J``, ``e``
    (the same inputs; position limits without rate limits, so that nothing but
    ``-λ J1⁺ e`` acts) and on redservo's (``J1 = L J`` from redservo's kinematics)."""
    from redservo import JointLimits, make_law

    robot, q, task, scene = case.robot, case.q, case.task, case.scene
    bMc, J = robot.kinematics(q)
    st = task.evaluate(scene, bMc, J, 0.0)
    lim = JointLimits(case.limits.q_min, case.limits.q_max)
    law = make_law("classical")

    def qdot(J1: Any, e1: Any) -> Any:
        return law(J1=J1, e1=e1, q=q, limits=lim, lam=case.lam, dt=case.dt).qdot

    return {
        "J": float(np.max(np.abs(J - visp["J"]))),
        "L": float(np.max(np.abs(st.L - visp["L"]))),
        "e": float(np.max(np.abs(st.e - visp["e"]))),
        "qdot, ViSP's J1 and e": float(
            np.max(np.abs(qdot(visp["L"] @ visp["J"], visp["e"]) - visp["qdot"]))
        ),
        "qdot, redservo's J1 and e": float(np.max(np.abs(qdot(st.L @ J, st.e) - visp["qdot"]))),
    }
