"""One BLAS thread while compiled kernels run (redservo.kernels.blas): the context manager,
and the loops that run inside it (campaign jobs and workers, simulate, the servo loop)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from redservo.kernels.blas import one_blas_thread

ROOT = Path(__file__).resolve().parents[1]


def _blas_threads() -> set[int]:
    """The thread counts of the BLAS libraries loaded in this process."""
    import scipy.linalg.cython_blas  # noqa: F401  (the kernels' BLAS)

    counts = {int(lib["num_threads"]) for lib in threadpool_info() if lib["user_api"] == "blas"}
    assert counts, "no BLAS library found"
    return counts


def test_one_thread_inside_and_the_previous_limits_restored_after() -> None:
    with threadpool_limits(limits=2):  # a known starting point, whatever the machine
        assert _blas_threads() == {2}
        with one_blas_thread():
            assert _blas_threads() == {1}
            with one_blas_thread():  # nested: still one, and not restored on the inner exit
                assert _blas_threads() == {1}
            assert _blas_threads() == {1}
        assert _blas_threads() == {2}


def test_restored_when_the_block_raises() -> None:
    with threadpool_limits(limits=2):
        with pytest.raises(ZeroDivisionError), one_blas_thread():
            1 / 0
        assert _blas_threads() == {2}


def test_campaign_jobs_run_with_one_blas_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every run of a campaign job (the compiled loop and the reachability search)."""
    import redservo.campaign.task as ctask
    from redservo.campaign import load_campaign, run_campaign

    seen: list[set[int]] = []
    run = ctask._run_task

    def spy(task: Any) -> Any:
        seen.append(_blas_threads())
        return run(task)

    monkeypatch.setattr(ctask, "_run_task", spy)
    with threadpool_limits(limits=2):
        run_campaign(
            load_campaign("afma6-gaze-demo"),
            samples=1,
            methods=["classical"],
            workers=1,
            progress=False,
        )
        assert _blas_threads() == {2}
    assert seen == [{1}]


def test_simulate_runs_with_one_blas_thread() -> None:
    from redservo.experiment.build import build
    from redservo.scenario import load_scenario

    exp = build(load_scenario("panda-4points"))
    seen: list[set[int]] = []
    with threadpool_limits(limits=2):
        exp.run(max_iterations=3, progress=lambda it: seen.append(_blas_threads()))
        assert _blas_threads() == {2}
    assert seen == [{1}] * 3


def test_the_servo_loop_runs_with_one_blas_thread() -> None:
    from tests.test_servo_loop import _loop, _setup

    clock, robot, sim, src, task = _setup()
    seen: list[set[int]] = []

    class Reading:
        def read_joints(self) -> Any:
            seen.append(_blas_threads())
            return sim.read_joints()

        def send_velocity(self, qdot: Any) -> None:
            sim.send_velocity(qdot)

        def stop(self) -> None:
            sim.stop()

    with threadpool_limits(limits=2):
        res = _loop(Reading(), src, robot, task, clock, max_iterations=3).run()
        assert _blas_threads() == {2}
    assert res.iterations == 3 and seen and all(s == {1} for s in seen)


def test_a_local_campaign_worker_is_pinned_for_its_life() -> None:
    """The pool's initializer (a subprocess stands for the worker): one BLAS thread, and the
    environment variables set for the libraries loaded later."""
    code = (
        "import os, scipy.linalg.cython_blas\n"
        "from threadpoolctl import threadpool_limits, threadpool_info\n"
        "threadpool_limits(limits=2)\n"
        "from redservo.campaign.engine import _worker_start\n"
        "_worker_start(os.getppid())\n"
        "print(sorted({i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'}),"
        " os.environ['OPENBLAS_NUM_THREADS'], os.environ['OMP_NUM_THREADS'])\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), *sys.path])}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["[1]", "1", "1"]
