"""The documentation site: ``mkdocs build --strict`` succeeds (a broken link, a missing page
or an API reference to a name that does not exist fails it), and the reference page of
outcomes and flags says what the code says.

The flag table of docs/reference/outcomes-and-flags.md is generated from the code's flag
table (``redservo.redundancy.flags.Flag``: each member's value and docstring, read with
``ast`` since an enum member's docstring is not kept at run time). After changing a flag,
regenerate it with ``python tests/test_docs_site.py --write``.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "reference" / "outcomes-and-flags.md"
FLAGS_SOURCE = ROOT / "src" / "redservo" / "redundancy" / "flags.py"


def flag_rows() -> list[tuple[str, str, str]]:
    """``(label, member name, docstring)`` of every member of ``Flag``, in source order."""
    tree = ast.parse(FLAGS_SOURCE.read_text(encoding="utf-8"))
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Flag")
    rows = []
    body = cls.body
    for node, after in zip(body, [*body[1:], None]):
        if not (isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant)):
            continue
        name = node.targets[0].id  # type: ignore[attr-defined]
        doc = ""
        if isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant):
            doc = " ".join(str(after.value.value).split())
        rows.append((str(node.value.value), name, doc))
    return rows


def flag_table() -> str:
    """The Markdown table between the ``flags`` markers of the page."""
    lines = [
        "| flag (`label`) | enum member | meaning [value attached] |",
        "|---|---|---|",
    ]
    for label, name, doc in flag_rows():
        cell = doc.replace("|", "\\|")
        lines.append(f"| `{label}` | `Flag.{name}` | {cell} |")
    return "\n".join(lines)


def _section(text: str, marker: str) -> str:
    m = re.search(rf"<!-- {marker}:start -->\n(.*?)\n<!-- {marker}:end -->", text, re.S)
    assert m, f"{PAGE.name}: no <!-- {marker}:start/end --> section"
    return m.group(1)


def _first_column(table: str) -> list[str]:
    return [row.split("|")[1].strip().strip("`") for row in table.splitlines()[2:] if row.strip()]


def write_page() -> None:
    """Rewrite the generated flag table of the page."""
    text = PAGE.read_text(encoding="utf-8")
    old = _section(text, "flags")
    PAGE.write_text(text.replace(old, flag_table()), encoding="utf-8")


def test_flag_table_is_generated_from_the_code() -> None:
    from redservo.redundancy.flags import FLAGS

    assert {label for label, _, _ in flag_rows()} == {f.label for f in FLAGS}
    assert all(doc for _, _, doc in flag_rows()), "every Flag member has a docstring"
    assert _section(PAGE.read_text(encoding="utf-8"), "flags") == flag_table(), (
        "docs/reference/outcomes-and-flags.md is out of date with redundancy/flags.py: "
        "run python tests/test_docs_site.py --write"
    )


def test_every_outcome_is_documented_once() -> None:
    from redservo.hardware import SERVO_OUTCOMES
    from redservo.records import OUTCOMES

    text = PAGE.read_text(encoding="utf-8")
    assert _first_column(_section(text, "outcomes")) == list(OUTCOMES)
    assert sorted(_first_column(_section(text, "servo-outcomes"))) == sorted(SERVO_OUTCOMES)


def test_readme_lists_every_docs_page() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    pages = sorted(p.name for p in (ROOT / "docs").glob("*.md"))
    missing = [p for p in pages if f"docs/{p}" not in readme]
    assert not missing, f"README.md's Documentation list misses {missing}"


def test_architecture_lists_only_existing_modules() -> None:
    """Every module or package named in docs/architecture.md's layout exists under src/."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    layout = text.split("```")[1]
    src = ROOT / "src" / "redservo"
    named = set(re.findall(r"(?<![\w/.])((?:[a-z_]+/)*[a-z_][a-z_0-9]*\.py)\b", layout))
    named |= set(re.findall(r"^ {2}([a-z_]+/) ", layout, re.M))  # the packages
    missing = [n for n in sorted(named) if not any(src.rglob(n.rstrip("/").split("/")[-1]))]
    assert not missing, f"docs/architecture.md lists modules that do not exist: {missing}"


def test_every_docs_page_is_in_the_nav() -> None:
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    pages = sorted(p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").rglob("*.md"))
    missing = [p for p in pages if f" {p}" not in nav]
    assert not missing, f"mkdocs.yml's nav misses {missing}"


def test_site_builds_strictly(tmp_path: Path) -> None:
    for module in ("mkdocs", "mkdocstrings", "material"):
        if importlib.util.find_spec(module) is None:
            pytest.skip(f"{module} is not installed: pip install -e '.[docs]' (make test does)")
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=600,
    )
    took = time.perf_counter() - t0
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout}\n{proc.stderr}"
    assert (tmp_path / "site" / "reference" / "api" / "index.html").is_file()
    html = (tmp_path / "site" / "reference" / "control" / "index.html").read_text("utf-8")
    assert "Controller" in html and "make_law" in html, "the API reference has no docstrings"
    print(f"mkdocs build --strict: {took:.1f} s")


if __name__ == "__main__":
    if "--write" in sys.argv:
        write_page()
        print(f"wrote the flag table of {PAGE}")
    else:
        print(flag_table())


def test_every_make_step_says_what_it_does() -> None:
    """make demo / test / docs: each step that can take more than a few seconds (install,
    lint, type-check, tests, the site) first prints one ``== ...`` line saying what it does."""
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    recipes = dict(re.findall(r"^([$()\w./-]+):[^\n=]*\n((?:\t[^\n]*\n)+)", makefile, re.M))
    for target in ("$(STAMP)", "$(TSTAMP)", "$(DSTAMP)", "lint", "typecheck", "pytest", "docs"):
        first = recipes[target].splitlines()[0].strip()
        assert first.startswith('@echo "== '), f"make {target}: first line {first!r}"
    assert "docs" in re.search(r"^\.PHONY:(.*)$", makefile, re.M).group(1).split()


def test_the_heartbeat_names_the_long_step(monkeypatch: pytest.MonkeyPatch) -> None:
    """make test's pytest plugin (tests/heartbeat.py) says what runs, and for how long."""
    from tests import heartbeat

    monkeypatch.setitem(heartbeat._state, "collecting", None)
    monkeypatch.setitem(heartbeat._state, "running", {})
    monkeypatch.setitem(heartbeat._state, "quiet", 0.0)
    heartbeat.pytest_runtest_logstart("tests/test_x.py::test_y", None)
    since = heartbeat._state["running"]["tests/test_x.py::test_y"]
    assert heartbeat.line(since + 20.2) == "\n  … still running tests/test_x.py::test_y (20 s)\n"
    heartbeat.pytest_runtest_logfinish("tests/test_x.py::test_y", None)
    assert heartbeat.line(since + 30.0) is None
    assert "-p tests.heartbeat" in (ROOT / "Makefile").read_text(encoding="utf-8")


def test_the_heartbeat_command_returns_the_exit_code_and_talks(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from tests import heartbeat

    code = "import sys, time; time.sleep(0.3); sys.exit(3)"
    assert heartbeat.run([sys.executable, "-c", code], every=0.05) == 3
    assert "still running (" in capsys.readouterr().err


def test_the_getting_started_python_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The Python blocks of docs/getting-started.md run, in order, in a fresh folder."""
    text = (ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 2
    monkeypatch.chdir(tmp_path)
    scope: dict[str, object] = {}
    for block in blocks:
        exec(compile(block, "getting-started.md", "exec"), scope)
    assert (tmp_path / "runs" / "gaze" / "summary.json").is_file()


def test_make_demo_says_when_a_step_is_quiet_for_long(capsys: pytest.CaptureFixture[str]) -> None:
    """examples/demo.py runs each step under a Watch: a step that writes nothing for ``every``
    seconds gets a ``… still working on`` line on stderr."""
    spec = importlib.util.spec_from_file_location("demo", ROOT / "examples" / "demo.py")
    assert spec is not None and spec.loader is not None
    demo = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(demo)
    with demo.Watch("redservo quiet", every=0.05) as watch:
        assert watch.said.wait(60.0)  # the watch's own thread sets it once it has spoken
    assert "… still working on redservo quiet (" in capsys.readouterr().err
    assert sys.stdout is not watch and "Tap" not in type(sys.stderr).__name__


def _make(*args: str) -> str:
    done = subprocess.run(
        ["make", "-s", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_make_says_which_system_packages_it_installs_and_how_to_skip(tmp_path: Path) -> None:
    """make test installs Chromium and EGL with apt-get only as root, saying what and how to
    skip; CHROMIUM_INSTALL=0 / EGL_INSTALL=0 skip (a stand-in apt-get records the calls)."""
    log = tmp_path / "apt.log"
    fake = tmp_path / "apt-get"
    fake.write_text(f'#!/bin/sh\necho "$@" >> {log}\n')
    fake.chmod(0o755)
    missing = ["CHROMIUM=/nonexistent/chromium", f"APT_GET={fake}"]
    said = _make("chromium", *missing, "CHROMIUM_INSTALL=0")
    assert said == (
        "chromium: not installed (CHROMIUM_INSTALL=0): the viewer's browser test will be skipped\n"
    )
    assert not log.exists()
    if os.geteuid() != 0:
        assert "needs root and apt-get" in _make("chromium", *missing)
        return
    said = _make("chromium", *missing)
    assert said == (
        "== installing Debian's chromium with apt-get as root, for the viewer's browser test "
        "(skip: make test CHROMIUM_INSTALL=0)\n"
    )
    assert log.read_text().splitlines() == ["update -qq", "install -y -qq chromium"]
