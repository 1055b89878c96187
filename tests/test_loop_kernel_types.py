"""The campaign loop's law step (``loop_kernel._law``, a kernel that links every law) has one
compiled version whether a compiled caller or Python calls it: numba types a ``*args``
parameter as a ``StarArgTuple`` in a compiled caller and as a ``Tuple`` from Python, so the
loop's body run as plain Python (tests/test_campaign_fast.py) compiled the whole law chain
a second time (5-8 CPU-s of ``make test``)."""

from __future__ import annotations

import inspect
from typing import Any

import pytest

pytest.importorskip("numba", reason="the compiled campaign loop needs numba (redservo[fast])")

from redservo.campaign import loop_kernel
from redservo.campaign.fastloop import campaign_law, fast_summary
from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario


def test_the_law_step_takes_named_arguments() -> None:
    params = inspect.signature(loop_kernel._law.py_func).parameters.values()
    assert all(p.kind is p.POSITIONAL_OR_KEYWORD for p in params)


def test_the_loop_body_run_from_python_compiles_no_second_law_step(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """After the compiled loop ran (its law step compiled, or loaded from the disk cache),
    the loop's body run as Python calls the law step with the version the loop uses."""
    from numba.core import event

    exp = build(apply_overrides(load_scenario("cm01-gaze"), ["simulation.max_iterations=3"]))
    law = campaign_law(exp, "iterative-smooth", None)
    assert fast_summary(exp, law) is not None
    compiled: list[str] = []

    class Listener(event.Listener):
        def on_start(self, ev: Any) -> None:
            compiled.append(getattr(ev.data["dispatcher"].py_func, "__name__", "?"))

        def on_end(self, ev: Any) -> None:
            pass

    listener = Listener()
    event.register("numba:compile", listener)
    try:
        kernel: Any = loop_kernel.closed_loop
        monkeypatch.setattr(loop_kernel, "closed_loop", kernel.py_func)
        assert fast_summary(exp, law) is not None
    finally:
        event.unregister("numba:compile", listener)
    assert "_law" not in compiled, compiled
