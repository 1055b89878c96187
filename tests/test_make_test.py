"""``make test`` on two pytest-xdist workers: the heartbeat, the groups, the Makefile's step."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from types import SimpleNamespace

import pytest

from tests import conftest, heartbeat

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def quiet_heartbeat(monkeypatch: pytest.MonkeyPatch) -> None:
    """The plugin's state as after the collection, with no test running and the terminal
    silent since long ago."""
    monkeypatch.setitem(heartbeat._state, "collecting", None)
    monkeypatch.setitem(heartbeat._state, "running", {})
    monkeypatch.setitem(heartbeat._state, "quiet", 0.0)


def test_the_heartbeat_names_each_long_test_of_two_workers(quiet_heartbeat: None) -> None:
    """Under xdist the controller hears two tests start before either ends: both are named,
    and the end of one does not silence the other."""
    heartbeat.pytest_runtest_logstart("tests/test_a.py::test_long", None)
    start = heartbeat._state["running"]["tests/test_a.py::test_long"]
    heartbeat.pytest_runtest_logstart("tests/test_b.py::test_longer", None)
    heartbeat._state["running"]["tests/test_b.py::test_longer"] = start - 15.0
    assert heartbeat.line(start + 20.2) == (
        "\n  … still running tests/test_a.py::test_long (20 s)\n"
        "\n  … still running tests/test_b.py::test_longer (35 s)\n"
    )
    heartbeat.pytest_runtest_logfinish("tests/test_a.py::test_long", None)
    assert heartbeat.line(start + 30.0) == (
        "\n  … still running tests/test_b.py::test_longer (45 s)\n"
    )


def test_the_heartbeat_speaks_after_ten_silent_seconds_whatever_runs(quiet_heartbeat: None) -> None:
    """A line once the terminal has had no dot for EVERY s, even when each of the running tests
    started less than EVERY s ago; none while dots come."""
    heartbeat.pytest_runtest_logstart("tests/test_a.py::test_one", None)
    heartbeat.pytest_runtest_logfinish("tests/test_a.py::test_one", None)  # its dot
    dot = heartbeat._state["quiet"]
    heartbeat.pytest_runtest_logstart("tests/test_a.py::test_two", None)
    heartbeat._state["running"]["tests/test_a.py::test_two"] = dot + 4.5
    assert heartbeat.line(dot + heartbeat.EVERY - 0.5) is None
    assert heartbeat.line(dot + heartbeat.EVERY + 0.5) == (
        "\n  … still running tests/test_a.py::test_two (6 s)\n"
    )


def test_a_crashed_worker_does_not_leave_its_test_running(quiet_heartbeat: None) -> None:
    """xdist reports a test whose worker died with ``when="???"`` and no logfinish."""
    heartbeat.pytest_runtest_logstart("tests/test_a.py::test_crash", None)
    heartbeat.pytest_runtest_logreport(
        SimpleNamespace(when="???", nodeid="tests/test_a.py::test_crash")
    )
    assert heartbeat._state["running"] == {}


def test_the_collection_is_announced_until_the_first_test_starts(
    monkeypatch: pytest.MonkeyPatch, quiet_heartbeat: None
) -> None:
    """The xdist controller collects nothing itself: its first news is a worker's test."""
    monkeypatch.setitem(heartbeat._state, "collecting", 100.0)
    assert heartbeat.line(130.4) == "\n  … collecting the tests (30 s)\n"
    heartbeat.pytest_runtest_logstart("tests/test_a.py::test_first", None)
    assert heartbeat._state["collecting"] is None


def test_the_heartbeat_talks_in_the_xdist_controller_only(monkeypatch: pytest.MonkeyPatch) -> None:
    started: list[str] = []

    def thread(**kw: object) -> SimpleNamespace:
        return SimpleNamespace(start=lambda: started.append(str(kw["name"])))

    monkeypatch.setattr(heartbeat.threading, "Thread", thread)
    heartbeat.pytest_configure(SimpleNamespace(workerinput={"workerid": "gw0"}))
    assert started == []
    heartbeat.pytest_configure(SimpleNamespace())
    assert started == ["pytest-heartbeat"]


def _item(tmp_path: Path, name: str, scopes: tuple[str, ...] = ()) -> SimpleNamespace:
    defs = {
        f"f{i}": [SimpleNamespace(scope=s, baseid=f"tests/{name}")] for i, s in enumerate(scopes)
    }
    return SimpleNamespace(
        fspath=tmp_path / name, _fixtureinfo=SimpleNamespace(name2fixturedefs=defs)
    )


@pytest.mark.parametrize(
    ("name", "scopes", "group"),
    [
        ("test_ros2_servo.py", (), "ros2"),
        ("test_ros2_tracking.py", ("module",), "ros2"),
        ("test_viewer.py", (), "loopback"),
        ("test_campaign_dask.py", (), "loopback"),
        ("test_repro_mc05.py", ("function", "module"), "file:test_repro_mc05.py"),
        ("test_repro_cm01_gaze.py", ("session",), "file:test_repro_cm01_gaze.py"),
        ("test_spatial.py", ("function",), None),
        ("test_loop_rows.py", (), "file:test_loop_rows.py"),
    ],
)
def test_tests_that_share_a_resource_or_a_module_fixture_stay_on_one_worker(
    tmp_path: Path, name: str, scopes: tuple[str, ...], group: str | None
) -> None:
    assert conftest.xdist_group(_item(tmp_path, name, scopes)) == group


def test_make_test_runs_pytest_on_two_workers_after_the_warm_up() -> None:
    """The Makefile's pytest step uses xdist with the groups, the `test` extra installs it,
    and the kernels are compiled once (``redservo warmup``) before the workers start."""
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    recipe = re.search(r"^pytest:[^\n]*\n((?:\t[^\n]*\n)+)", makefile, re.M)
    assert recipe is not None
    assert "-n $(PYTEST_WORKERS) --dist loadgroup" in recipe.group(1)
    assert re.search(r"^PYTEST_WORKERS \?= 2$", makefile, re.M)
    assert "-p tests.heartbeat" in recipe.group(1)
    assert re.search(r"^pytest:[^\n]*\bwarm\b", makefile, re.M), "pytest runs after the warm-up"
    with (ROOT / "pyproject.toml").open("rb") as f:
        extra = tomllib.load(f)["project"]["optional-dependencies"]["test"]
    assert any(re.fullmatch(r"pytest-xdist>=[\d.]+", req) for req in extra), extra


def _recipe(makefile: str, target: str) -> str:
    """A Makefile target's line (with its prerequisites) and its recipe."""
    found = re.search(rf"^{re.escape(target)}:[^\n]*\n(?:\t[^\n]*\n)+", makefile, re.M)
    assert found is not None, target
    return found.group(0)


def test_make_test_starts_the_tests_right_after_the_warm_up() -> None:
    """No one-core step between the warm-up and pytest: the worked examples' chain compiles in
    its two tests (one xdist group) on one worker while the other runs tests."""
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    test = _recipe(makefile, "test")
    assert "-j2 typecheck warm\n" in test and "warm-examples" not in test
    assert "warm-examples" not in _recipe(makefile, "pytest").splitlines()[0]
    assert "tests.examples_cache" in _recipe(makefile, "warm-examples")  # still there alone


def test_pip_installs_without_byte_compiling_every_package() -> None:
    """pip's byte-compilation of all 11,500 modules it installs is the install's largest CPU
    item; Python compiles the ones a command imports instead."""
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    installs = [ln for ln in makefile.splitlines() if "pip install" in ln and " -e " in ln]
    assert len(installs) == 3
    assert all("--no-compile" in ln for ln in installs), installs


def test_each_example_run_seeds_the_examples_cache_first(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The tests that run the worked examples copy the warm-up's kernels to the examples' cache
    themselves (``make test`` no longer runs tests/examples_cache.py before them), then run the
    example with that cache."""
    from tests import examples_cache

    src = tmp_path / "pkg" / "kernels"
    (src / "__pycache__").mkdir(parents=True)
    (src / "__pycache__" / "k.f-1.py311.nbi").write_bytes(b"package")
    cache = tmp_path / "cache"
    monkeypatch.setattr(examples_cache, "CACHE", cache)
    monkeypatch.setattr(examples_cache, "PACKAGE_KERNELS", (src,))
    seen: list[tuple[list[str], str]] = []

    def run(cmd: list[str], env: dict[str, str], **_: object) -> SimpleNamespace:
        seen.append(([p.name for p in cache.rglob("*.nbi")], env["NUMBA_CACHE_DIR"]))
        return SimpleNamespace(returncode=0)

    monkeypatch.setattr(examples_cache.subprocess, "run", run)
    examples_cache.run_example("scara_robot")
    assert seen == [(["k.f-1.py311.nbi"], str(cache))]
