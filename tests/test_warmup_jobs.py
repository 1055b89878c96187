"""`redservo warmup --jobs N`: the warm-up's parts on N forked processes."""

from __future__ import annotations

import io
import multiprocessing
import os
from pathlib import Path

import pytest

from redservo.bench import warmup as wu
from redservo.bench import warmup_jobs as wj
from redservo.bench import warmup_parts as wp
from redservo.cli.entry import main
from redservo.errors import ConfigurationError


def _numba_on() -> bool:
    from redservo.kernels import compiled

    return compiled()


needs_fork_numba = pytest.mark.skipif(
    not _numba_on() or "fork" not in multiprocessing.get_all_start_methods(),
    reason="forked workers compiling with numba",
)


def _groups(log: Path) -> tuple[wu.Group, ...]:
    """Two groups with parts and one without; each part compiles a new function once and
    writes the pid of the process it ran in; the first part is done before any other starts
    (it compiles what they all call), and the parts of a family (``a-``, ``b-``) share a
    worker."""

    def run_part(part: str, note: wu.Note) -> None:
        import numba

        if part != "a-1" and not (log / "a-1.pid").exists():
            raise AssertionError(f"{part} started before the first part was done")

        @numba.njit(cache=False)
        def f(x: float) -> float:
            return x + 1.0

        f(1.0)
        (log / f"{part}.pid").write_text(str(os.getpid()))
        if part == "b-2":
            note("b-2 skipped half: needs nothing")

    parts_a, parts_b = ("a-1", "a-2", "a-3"), ("b-1", "b-2")
    return (
        wu.Group("A", "first", lambda note: None, lambda: parts_a, run_part),
        wu.Group("B", "second", lambda note: None, lambda: parts_b, run_part),
        wu.Group("C", "whole", lambda note: run_part("C", note)),
    )


@needs_fork_numba
def test_jobs_run_every_part_in_worker_processes_and_sum_per_group(tmp_path: Path) -> None:
    buf = io.StringIO()
    report = wj.warmup_jobs(2, groups=_groups(tmp_path), stream=buf)
    pids = {p.stem: int(p.read_text()) for p in tmp_path.glob("*.pid")}
    assert set(pids) == {"a-1", "a-2", "a-3", "b-1", "b-2", "C"}  # nothing skipped
    assert os.getpid() not in pids.values()  # none ran in this process
    assert pids["a-2"] == pids["a-3"] and pids["b-1"] == pids["b-2"]  # a family, one worker
    assert report.numba and report.compiled == {"A": 3, "B": 2, "C": 1}
    assert set(report.seconds) == {"A", "B", "C"}
    lines = buf.getvalue().splitlines()
    assert lines[0] == "warmup: 6 parts of 3 groups on 2 processes ..."
    done = sorted(line.split("]")[0] for line in lines if line.startswith("  ["))
    assert done == sorted(f"  [{n}/6" for n in range(1, 7))
    assert "  B: b-2 skipped half: needs nothing" in lines
    assert "  A: " in "\n".join(lines) and "3 compilation(s)" in buf.getvalue()
    assert lines[-1].startswith("warmup: done in ") and "6 kernel compilation(s)" in lines[-1]


def test_one_job_is_the_plain_warmup(tmp_path: Path) -> None:
    buf = io.StringIO()
    groups = (wu.Group("none", "nothing", lambda note: None),)
    report = wj.warmup_jobs(1, groups=groups, stream=buf)
    assert buf.getvalue().splitlines()[0] == "warmup [1/1] none: nothing ..."
    assert set(report.seconds) == {"none"}


def test_the_parts_of_the_shipped_groups_are_the_whole_groups() -> None:
    """Every shipped group is split into parts, and running them all is the group."""
    for group in wu.GROUPS:
        assert group.parts is not None and group.run_part is not None, group.name
        parts = group.parts()
        assert parts and len(set(parts)) == len(parts), group.name


def test_jobs_below_one_is_one_clear_error() -> None:
    with pytest.raises(ConfigurationError, match="--jobs must be at least 1, got 0"):
        wj.warmup_jobs(0)


def test_the_command_line_refuses_zero_jobs(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["warmup", "--jobs", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "redservo: error: argument --jobs: must be in [1, 64], got 0 (see 'redservo warmup --help')"
    ]


def test_make_test_warms_up_on_two_processes_and_reports_the_gaps() -> None:
    """`make test` compiles on both cores, then its summary names the kernels the tests still
    compiled (tests/compile_report.py) and the slowest tests."""
    import re

    makefile = (Path(__file__).resolve().parent.parent / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"^WARM_JOBS \?= 2$", makefile, re.M)
    assert "$(BIN)/redservo warmup --jobs $(WARM_JOBS)\n" in makefile
    recipe = re.search(r"^pytest:[^\n]*\n((?:\t[^\n]*\n)+)", makefile, re.M)
    assert recipe is not None
    assert "-p tests.compile_report" in recipe.group(1) and "--durations=" in recipe.group(1)


def test_the_examples_cache_is_seeded_where_numba_looks_and_keeps_its_own(tmp_path: Path) -> None:
    """tests/examples_cache.py copies the package's cached kernels to the directory numba
    reads under NUMBA_CACHE_DIR, every index and data file, never one the examples wrote."""
    from tests.examples_cache import seed

    src = tmp_path / "pkg" / "kernels"
    (src / "__pycache__").mkdir(parents=True)
    for name in ("k.f-1.py311.nbi", "k.f-1.py311.1.nbc", "k.cpython-311.pyc"):
        (src / "__pycache__" / name).write_bytes(b"package")
    cache = tmp_path / "cache"
    numba = pytest.importorskip("numba")
    from numba.core.caching import _CacheLocator

    dest = cache / _CacheLocator.get_suitable_cache_subpath(str(src / "k.py"))
    dest.mkdir(parents=True)
    (dest / "k.f-1.py311.nbi").write_bytes(b"examples")  # the examples' own index
    assert numba and seed(cache, (src,)) == 1
    assert sorted(p.name for p in dest.iterdir()) == ["k.f-1.py311.1.nbc", "k.f-1.py311.nbi"]
    assert (dest / "k.f-1.py311.nbi").read_bytes() == b"examples"
    assert (dest / "k.f-1.py311.1.nbc").read_bytes() == b"package"
    assert seed(cache, (src,)) == 0


@needs_fork_numba
def test_groups_without_a_step_start_beside_the_first_part_and_a_chain_keeps_one_worker(
    tmp_path: Path,
) -> None:
    """A group that calls no step kernel (the reachability searches) compiles while the first
    part does; a group that names its chain (the campaign loop) runs its first part, which
    compiles the chain, before its others, whatever robot their names say."""
    import time

    def run_part(part: str, note: wu.Note) -> None:
        if part == "a-1":  # the first part waits until the step-free group has started
            for _ in range(600):
                if (tmp_path / "r-1.pid").exists():
                    break
                time.sleep(0.1)
            assert (tmp_path / "r-1.pid").exists(), "r-1 waited for the first part"
        elif part.startswith(("x", "y")):
            assert (tmp_path / "a-1.pid").exists(), f"{part} started before the first part"
        if part == "y-1":
            assert (tmp_path / "x-1.pid").exists(), "y-1 started before its chain's head"
        (tmp_path / f"{part}.pid").write_text(str(os.getpid()))

    groups = (
        wu.Group("A", "first", lambda note: None, lambda: ("a-1", "a-2"), run_part),
        wu.Group("R", "no step", lambda note: None, lambda: ("r-1",), run_part, "r", False),
        wu.Group("C", "a chain", lambda note: None, lambda: ("x-1", "y-1"), run_part, "c"),
    )
    report = wj.warmup_jobs(2, groups=groups, stream=io.StringIO())
    pids = {p.stem: int(p.read_text()) for p in tmp_path.glob("*.pid")}
    assert set(pids) == {"a-1", "a-2", "r-1", "x-1", "y-1"}
    assert pids["a-1"] != pids["r-1"]
    assert set(report.seconds) == {"A", "R", "C"}


def test_the_campaigns_share_one_worker_and_their_searches_need_no_step() -> None:
    """The shipped warm-up: every campaign runs the one campaign-loop kernel and every
    scenario the Controller's, so each group is a chain; the reachability searches call no
    law, so they start at once."""
    by_name = {g.name: g for g in wu.GROUPS}
    assert by_name["campaign loop"].chain and by_name["campaign loop"].steps
    assert by_name["scenarios"].chain not in ("", by_name["campaign loop"].chain)
    assert by_name["reachability"].chain and not by_name["reachability"].steps
    assert wu.GROUPS[0].steps  # the first part compiles the step: it runs first


def test_a_heavy_part_is_handed_out_before_the_larger_families_of_its_chain() -> None:
    """A part that compiles much of its own (the realistic camera's image pipeline) goes first
    after its chain's head, not last as a family of one: run last, it kept one core busy
    alone for the warm-up's last 18 s (340 s at a load of 15)."""

    def part(name: str, note: wu.Note) -> None:
        pass

    scenarios = ("a-1", "p-1", "p-2", "p-3", "camera", "q-1", "q-2")
    groups = (
        wu.Group("L", "laws", lambda note: None, lambda: ("law",), part),
        wu.Group(
            "S", "a chain", lambda note: None, lambda: scenarios, part, "c", heavy=("camera",)
        ),
    )
    plan = wj._plan(wj._tasks(groups), groups)
    assert plan.heads == {"c": (1, "a-1")}
    names = [[p for _, p in family] for family in plan.chained["c"]]
    assert names == [["camera"], ["p-1", "p-2", "p-3"], ["q-1", "q-2"]]
    assert wu.GROUPS[1].heavy == wp.HEAVY_SCENARIOS
    assert set(wp.HEAVY_SCENARIOS) <= set(wp.scenario_parts())
