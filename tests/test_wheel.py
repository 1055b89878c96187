"""The wheel builds and runs outside the source tree (issue 22, part 7).

The wheel is built offline by setuptools' PEP 517 hook (what ``pip wheel --no-deps
--no-build-isolation`` calls), from a copy of the sources so that the tree gets no build/ or
egg-info, installed with ``--no-deps`` into a
fresh virtual environment whose dependencies come from this one (a ``.pth`` line naming
this environment's site-packages: a plain path, so this environment's editable install of
the source tree is *not* picked up), and ``redservo list`` and a short ``redservo run`` are
run from a temporary folder. The kernels run uncompiled there (``REDSERVO_NO_NUMBA=1``): a
fresh install has no numba cache, and compiling is tested elsewhere.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("wheel") is None or importlib.util.find_spec("setuptools") is None,
    reason="building the wheel offline needs setuptools and wheel (pip install -e '.[test]')",
)


def _run(cmd: list[str], cwd: Path, env: dict[str, str] | None = None) -> str:
    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"{cmd}: {done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    return done.stdout


def test_the_wheel_installs_and_runs_outside_the_source_tree(tmp_path: Path) -> None:
    src = tmp_path / "source"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, src / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "*.nbi", "*.nbc")
    shutil.copytree(ROOT / "src", src / "src", ignore=ignore)
    dist = tmp_path / "dist"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "--no-input"]
    # The PEP 517 hook pip would call (pip wheel --no-build-isolation), ~2 s faster without pip.
    build = f"from setuptools.build_meta import build_wheel; build_wheel({str(dist)!r})"
    _run([sys.executable, "-c", build], cwd=src)
    (wheel,) = dist.glob("redservo-*.whl")

    env_dir = tmp_path / "env"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    py = env_dir / "bin" / "python"
    purelib = Path(_run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                        cwd=tmp_path).strip())  # fmt: skip
    (purelib / "host-deps.pth").write_text(sysconfig.get_path("purelib") + "\n")
    _run([*pip, "--python", str(py), "install", "--no-deps", "--no-index", str(wheel)],
         cwd=tmp_path)  # fmt: skip

    work = tmp_path / "work"
    work.mkdir()
    env = {**os.environ, "REDSERVO_NO_NUMBA": "1", "PYTHONPATH": ""}
    where = _run([str(py), "-c", "import redservo; print(redservo.__file__)"], work, env)
    assert Path(where.strip()).is_relative_to(env_dir), where  # the wheel, not the tree
    exe = str(env_dir / "bin" / "redservo")
    listing = _run([exe, "list"], work, env)
    assert "afma6-gaze-demo" in listing and "panda-urdf-4points" in listing
    out = _run([exe, "run", "afma6-gaze-demo", "--set", "simulation.max_iterations=10",
                "--no-plot", "-q", "--out", "run"], work, env)  # fmt: skip
    assert "afma6-gaze-demo [iterative-smooth]" in out
    assert (work / "run" / "scenario.toml").is_file() and (work / "run" / "log.npz").is_file()
    with __import__("zipfile").ZipFile(wheel) as zf:
        names = set(zf.namelist())
    assert "redservo/scenarios/cm01-gaze.toml" in names and "redservo/py.typed" in names
    for robot in ("franka_emika_panda/panda.xml", "universal_robots_ur5e/ur5e.xml"):
        xml = f"redservo/robots/data/menagerie/{robot}"
        assert xml in names and f"{xml.rsplit('/', 1)[0]}/LICENSE" in names, robot
    assert any(n.endswith("licenses/LICENSE") or n.endswith("/LICENSE") for n in names), names
