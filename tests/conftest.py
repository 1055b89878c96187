"""Test-session settings shared by every test module."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

# The suite checks the compiled kernels (and compares them with the plain ones where it says
# so): a cold cache must not switch a test process, or the commands it starts, to the plain
# kernels (redservo.bench.kernel_mode's `auto`). tests/test_kernel_mode.py clears it for its own
# processes.
os.environ.setdefault("REDSERVO_KERNELS", "compiled")

# `make test` runs the suite on two pytest-xdist workers (`-n 2 --dist loadgroup`). The tests
# of one group run on one worker, one after the other, as in a plain `pytest` run:
SHARED_RESOURCES = {
    # DDS on loopback: the domain ids are drawn from the test process's pid, per file.
    "test_ros2_": "ros2",
    # Free ports found by binding port 0 then released, a browser, a dask cluster.
    "test_viewer.py": "loopback",
    "test_campaign_dask.py": "loopback",
}
"""File-name prefix: xdist group of the tests that share a machine resource."""

ONE_COMPILATION = {
    # numba's own overloads (``impl``) under the loop's distance rows compile in each process
    # that calls them from Python, not from the disk cache: 43-46 per worker (tests/compile_report.py)
    "test_loop_rows.py": "the loop's distance rows called from Python",
}
"""Test files whose tests compile the same kernels in their process (not loaded from the disk
cache): their tests keep to one worker (group ``file:<name>``), which compiles them once."""


def xdist_group(item: Any) -> str | None:
    """The xdist group of a test: its shared resource (:data:`SHARED_RESOURCES`), else its
    file when its tests compile the same kernels in their process (:data:`ONE_COMPILATION`)
    or when it uses a module- or session-scoped fixture (computed once per worker: the
    file's tests stay together so it is computed once), else None (any worker)."""
    name = Path(str(item.fspath)).name
    for prefix, group in SHARED_RESOURCES.items():
        if name.startswith(prefix):
            return group
    if name in ONE_COMPILATION:
        return f"file:{name}"
    info = getattr(item, "_fixtureinfo", None)
    defs = [] if info is None else [d for ds in info.name2fixturedefs.values() for d in ds]
    if any(d.scope in ("module", "session") and d.baseid for d in defs):
        return f"file:{name}"
    return None


@pytest.hookimpl(tryfirst=True)  # before xdist reads the marks (its own hook of this name)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if not config.pluginmanager.hasplugin("xdist"):
        return
    for item in items:
        group = xdist_group(item)
        if group is not None:
            item.add_marker(pytest.mark.xdist_group(group))
