"""First use: `redservo warmup` compiles the kernels ahead with progress, and the first command
that compiles says so once, only when numba actually compiles (a cold cache)."""

from __future__ import annotations

import io
import multiprocessing
import os
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest

from redservo.bench import warmup as wu
from redservo.bench import warmup_parts as wp
from redservo.cli.entry import main


def _numba_on() -> bool:
    from redservo.kernels import compiled

    return compiled()


needs_numba = pytest.mark.skipif(not _numba_on(), reason="the notice is about numba compiling")


def _fresh_function() -> object:
    """A new numba function: its first call compiles (no cache), firing one compile event."""
    import numba

    @numba.njit(cache=False)
    def f(x: float) -> float:
        return x + 1.0

    return f


def test_warmup_runs_every_group_and_prints_progress() -> None:
    """The whole command on the plain-Python path (REDSERVO_NO_NUMBA=1: quick): one line per
    group started and finished with its time, then the total; exit code 0."""
    env = {**os.environ, "REDSERVO_NO_NUMBA": "1"}
    out = subprocess.run(
        [sys.executable, "-m", "redservo.cli.entry", "warmup"],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr
    err = out.stderr.splitlines()
    assert out.stdout == ""  # progress goes to stderr
    assert "numba is off" in err[0] and "nothing to compile" in err[0]
    n = len(wu.GROUPS)
    for i, group in enumerate(wu.GROUPS):
        assert f"warmup [{i + 1}/{n}] {group.name}: {group.what} ..." in err
        assert any(line.startswith(f"  {group.name}: ") and line.endswith(" s") for line in err)
    assert err[-1].startswith("warmup: done in ") and "nothing compiled" in err[-1]
    assert not [line for line in err if "skipped" in line]  # every extra is installed here


def test_warmup_quiet_prints_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    groups = (wu.Group("none", "nothing", lambda note: None),)
    report = wu.warmup(quiet=True, groups=groups)
    assert capsys.readouterr().err == "" and set(report.seconds) == {"none"}


@needs_numba
def test_warmup_counts_what_each_group_compiles_and_says_when_the_cache_was_warm() -> None:
    f = _fresh_function()

    def compile_it(note: Callable[[str], None]) -> None:
        f(1.0)  # type: ignore[operator]
        note("a part skipped: needs nothing")

    def call_again(note: object) -> None:
        f(2.0)  # type: ignore[operator]

    groups = (wu.Group("fresh", "a new function", compile_it),
              wu.Group("again", "the same one", call_again))  # fmt: skip
    buf = io.StringIO()
    report = wu.warmup(groups=groups, stream=buf)
    lines = buf.getvalue().splitlines()
    assert report.numba and report.compiled["fresh"] >= 1 and report.compiled["again"] == 0
    assert lines[0] == "warmup [1/2] fresh: a new function ..."
    assert lines[1] == "  fresh: a part skipped: needs nothing"
    assert lines[2].startswith("  fresh: ") and "kernel compilation(s)" in lines[2]
    assert "kernel compilation(s), now cached on disk" in lines[-1]

    buf = io.StringIO()
    report = wu.warmup(groups=groups[1:], stream=buf)  # already compiled: nothing to do
    assert report.compiled == {"again": 0}
    assert "the kernel cache was already warm (nothing compiled)" in buf.getvalue()


@needs_numba
def test_the_notice_is_printed_once_on_the_first_compilation() -> None:
    buf = io.StringIO()
    counter = wu.CompileCounter(notice=True, stream=buf)
    assert counter.install()
    try:
        _fresh_function()(1.0)  # type: ignore[operator]
        _fresh_function()(1.0)  # type: ignore[operator]
    finally:
        counter.uninstall()
    assert counter.count >= 2
    assert buf.getvalue() == wu.NOTICE + "\n"
    assert "redservo warmup" in wu.NOTICE and f"about {wu.COLD_SECONDS} s" in wu.NOTICE


@needs_numba
def test_the_notice_appears_on_a_cold_cache_and_not_on_a_warm_one(tmp_path: Path) -> None:
    """Two processes share an on-disk cache: the first compiles and says so, the second loads
    the cached code and says nothing (numba reports a compilation only on a cache miss)."""
    (tmp_path / "mod.py").write_text(
        "import numba\n\n@numba.njit(cache=True)\ndef f(x):\n    return 2.0 * x\n"
    )
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        from redservo.bench.warmup import announce_compilation
        announce_compilation()
        announce_compilation()  # idempotent: one listener
        import mod
        print(mod.f(1.5))
    """)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("REDSERVO_NO_NUMBA", None)
    runs = [
        subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True,
                       timeout=300)
        for _ in range(2)
    ]  # fmt: skip
    assert [r.stdout.strip() for r in runs] == ["3.0", "3.0"], [r.stderr for r in runs]
    first = runs[0].stderr.splitlines()
    assert first[0] == wu.NOTICE  # then progress lines only if it took over 8 s (busy machine)
    assert all(line.startswith("redservo: compil") for line in first[1:]), first
    assert runs[1].stderr == ""


def _compile_in_child() -> None:
    _fresh_function()(1.0)  # type: ignore[operator]


@needs_numba
@pytest.mark.skipif(
    "fork" not in multiprocessing.get_all_start_methods(), reason="forked workers only"
)
def test_forked_workers_share_the_notice(tmp_path: Path) -> None:
    """A campaign's workers are forked: the first of the process tree to compile prints."""
    log = tmp_path / "stderr.txt"
    with log.open("a", buffering=1) as stream:
        counter = wu.CompileCounter(notice=True, stream=stream)
        assert counter.install()
        try:
            child = multiprocessing.get_context("fork").Process(target=_compile_in_child)
            child.start()
            child.join(timeout=300)
            assert child.exitcode == 0
            _fresh_function()(1.0)  # type: ignore[operator]  # the parent compiles too
        finally:
            counter.uninstall()
    assert log.read_text() == wu.NOTICE + "\n"


def test_commands_that_run_control_steps_ask_for_the_notice(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    calls: list[int] = []
    monkeypatch.setattr(wu, "announce_compilation", lambda group: calls.append(group))
    assert main(["list", "-q"]) == 0
    assert calls == []  # listing compiles nothing: numba is not even imported for it
    argv = ["run", "afma6-gaze-demo", "--set", "simulation.max_iterations=3", "--no-plot", "-q"]
    assert main([*argv, "--out", str(tmp_path / "r")]) == 0
    assert calls == ["run"]  # the group its progress lines name


def test_the_scenario_group_warms_every_sphere_variant(monkeypatch: pytest.MonkeyPatch) -> None:
    """The reproduction runs CM01 eq. 27 with the sphere variants no shipped scenario uses;
    after `redservo warmup`, `redservo reproduce` must not compile (it did, mid-run)."""
    from redservo.features.sphere import SPHERE_VARIANTS, SphereFeature

    seen: list[str] = []
    original = SphereFeature.interaction

    def interaction(self: SphereFeature, s, inv_depth):  # type: ignore[no-untyped-def]
        seen.append(self.variant)
        return original(self, s, inv_depth)

    monkeypatch.setattr(SphereFeature, "interaction", interaction)
    wp.feature_variants()
    assert sorted(set(seen)) == sorted(SPHERE_VARIANTS)
