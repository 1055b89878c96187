"""The first run says what it compiles: group, count done/expected, elapsed, estimate, at
least every 10 s (a fake clock drives the reporter; no wall-clock dependence)."""

from __future__ import annotations

import io
from types import SimpleNamespace

from redservo.bench import compile_progress as cp
from redservo.bench import warmup as wu


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def _progress(expected: int | None = 10) -> tuple[cp.Progress, FakeClock, io.StringIO]:
    clock, out = FakeClock(), io.StringIO()
    p = cp.Progress("run", stream=out, clock=clock, ticker=False)
    p.set_group("run", expected)
    return p, clock, out


def test_the_line_names_group_count_elapsed_and_estimate() -> None:
    p, clock, out = _progress(10)
    for name in ("a", "b", "c", "d"):
        p.on_start(name)
        clock.now += 5.0
        p.on_end()
    p.on_start("sns_solve")
    clock.now += 2.0
    assert p.tick()  # still compiling: a progress line, the ticker goes on
    line = out.getvalue().strip()
    assert line == (
        "redservo: compiling [run] 4/~10 kernels, 22 s elapsed, about 33 s left (now: sns_solve)"
    )


def test_nested_compilations_keep_it_compiling_and_idle_ends_with_a_summary() -> None:
    p, clock, out = _progress(3)
    p.on_start("outer")
    p.on_start("inner")  # numba compiles a callee inside its caller
    p.on_end()
    clock.now += 30.0
    assert p.tick() and "(now: outer)" in out.getvalue()  # the kernel asked for
    p.on_end()
    clock.now += cp.EVERY  # nothing compiled for a whole period
    assert not p.tick()
    assert out.getvalue().splitlines()[-1] == "redservo: compiled 2 kernel(s) [run]; running"


def test_more_than_expected_and_unmeasured_groups_say_so() -> None:
    p, _clock, _ = _progress(1)
    for _ in range(2):
        p.on_start("k")
        p.on_end()
    assert p.line().endswith("2/~1 kernels, 0 s elapsed, more than expected: estimate unknown")
    p.set_group("some-new-command")
    bound, is_bound = cp.expected_for("some-new-command")
    assert is_bound and bound == sum(cp.EXPECTED[g] for g in cp._WARMUP) > 0
    p.on_start("k")
    assert f"0/≤{bound} kernels" in p.line()


def test_the_counter_forwards_numba_events_with_the_kernel_name() -> None:
    p, _, _ = _progress(5)
    counter = wu.CompileCounter(progress=p)
    event = SimpleNamespace(
        data={
            "dispatcher": SimpleNamespace(
                py_func=test_the_counter_forwards_numba_events_with_the_kernel_name
            )
        }
    )
    counter.on_start(event)
    assert p.current == "test_the_counter_forwards_numba_events_with_the_kernel_name"
    counter.on_end(event)
    assert (counter.count, p.done, p.depth) == (1, 1, 0)
    assert cp.kernel_name(SimpleNamespace(data=None)) == "?"


def test_every_measured_group_has_an_expected_count() -> None:
    assert all(cp.EXPECTED[g.name] > 0 for g in wu.GROUPS)
    assert cp.EXPECTED["run"] > 0


def test_make_demo_lines_name_the_step() -> None:
    """Every heartbeat of `make demo` says which of its steps runs (step i/n and command)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "demo.py"
    spec = importlib.util.spec_from_file_location("demo", path)
    assert spec is not None and spec.loader is not None
    demo = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(demo)
    assert demo.label(2, 5, ["reproduce", "--out", "x"]) == "step 2/5 (redservo reproduce)"


def test_the_end_of_a_command_closes_its_report_and_nothing_of_it_leaks_into_the_next() -> None:
    """``finish`` (the end of a ``redservo`` command): the closing line now if progress was
    printed, then silence; a new command's group starts counting afresh and talks again."""
    p, clock, out = _progress(10)
    p.on_start("a")
    clock.now += 9.0
    assert p.tick()  # a progress line
    p.on_end()
    p.finish()
    assert out.getvalue().splitlines()[-1] == "redservo: compiled 1 kernel(s) [run]; running"
    lines = len(out.getvalue().splitlines())
    clock.now += 1.0
    assert not p.tick()  # the ticker stops silently: nothing during the next command
    p.finish()  # twice is harmless
    assert len(out.getvalue().splitlines()) == lines
    p.set_group("compare", 5)
    p.on_start("b")
    clock.now += 9.0
    assert p.tick() and "[compare] 0/~5" in out.getvalue().splitlines()[-1]


def test_a_command_that_printed_no_progress_closes_silently() -> None:
    p, _, out = _progress(10)
    p.on_start("a")
    p.on_end()
    p.finish()
    assert out.getvalue() == ""


def test_a_ticker_left_from_the_previous_command_says_nothing_for_the_next() -> None:
    """The ticker thread wakes every 8 s: a command that starts (``set_group``) before it saw
    the previous one's ``finish`` must not hear a closing line for kernels it never compiled
    (``redservo: compiled 0 kernel(s) [run]; running`` broke a CLI test's one-line stderr)."""
    p, clock, out = _progress(10)
    p.on_start("a")
    clock.now += 9.0
    assert p.tick()
    p.on_end()
    p.finish()
    printed = out.getvalue()
    p.set_group("run")  # the next command, before the ticker woke up
    clock.now += cp.EVERY
    assert not p.tick()  # it stops
    assert out.getvalue() == printed
