"""One step kernel, three drivers (docs/architecture.md): no bench-only compiled step is left,
and the object path computes CM01 eq. 25 in one function, bit for bit the step kernel's."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

import redservo.task as task_module
from redservo.bench.cases import bench_cases


def test_the_bench_only_step_is_gone() -> None:
    """The benchmarks' whole-step kernel and its binding were a fourth driver of the step."""
    import redservo.binding
    from redservo.kernels import sensed

    assert importlib.util.find_spec("redservo.binding.step") is None
    assert not hasattr(redservo.binding, "compiled_step")
    assert not hasattr(sensed, "sensed_step") and "sensed_step" not in sensed.__all__


@pytest.mark.parametrize("with_c", [True, False])
def test_the_object_paths_eq_25_is_the_kernels_bit_for_bit(with_c: bool) -> None:
    from redservo.kernels.control import task_rows

    rng = np.random.default_rng(29)
    e, L, J = rng.normal(size=8), rng.normal(size=(8, 6)), rng.normal(size=(6, 7))
    C = rng.normal(size=(6, 8)) if with_c else None
    e1, J1 = task_module.task_rows(e, L, C, J)
    k1, kJ1 = task_rows(e, L, np.zeros((0, 0)) if C is None else C, J)
    assert e1.tobytes() == np.asarray(k1).tobytes()
    assert J1.tobytes() == np.asarray(kJ1).tobytes()
    if C is not None:
        assert e1.tobytes() == (C @ e).tobytes() and J1.tobytes() == ((C @ L) @ J).tobytes()


def _counted(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    real = task_module.task_rows

    def counted(*args: object) -> object:
        calls.append(1)
        return real(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(task_module, "task_rows", counted)
    return calls


@pytest.mark.parametrize("case", ["afma6-4points", "afma6-moments"])
def test_every_object_path_state_takes_eq_25_from_one_function(
    case: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The points' numpy path (kernels off), the points with a depth factor, and any other
    task (moments) all build ``e1``, ``J1`` through :func:`redservo.task.task_rows`."""
    from redservo.features import compiled_points

    c = next(x for x in bench_cases(scaling=()) if x.name == case)
    bMc, J = c.robot.kinematics(c.q)
    want = c.task.evaluate(c.scene, bMc, J, 0.0)
    calls = _counted(monkeypatch)
    monkeypatch.setattr(compiled_points, "compiled", lambda: False)
    got = c.task.evaluate(c.scene, bMc, J, 0.0)
    assert got.J1.tobytes() == want.J1.tobytes() and got.e1.tobytes() == want.e1.tobytes()
    c.task.evaluate(c.scene, bMc, J, 0.0, depth_scale=1.2)
    c.task.evaluate_measured(want.s, want.inv_depth, J)
    assert len(calls) == 3
