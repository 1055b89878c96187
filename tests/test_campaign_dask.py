"""Campaigns on a Dask cluster (``run_campaign(scheduler=...)``, ``redservo campaign --scheduler``).

The rows are those of a local run, the client alone writes them (so a rerun resumes), and
a real ``dask scheduler`` with two ``dask worker`` processes on 127.0.0.1 runs a campaign.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

distributed = pytest.importorskip(
    "distributed", reason="Dask campaigns need distributed (redservo[dask])"
)

from redservo.campaign import engine, load_campaign, run_campaign  # noqa: E402
from redservo.errors import ConfigurationError  # noqa: E402

METHODS = ["classical", "iterative-smooth", "qp"]


def _exact(rows: tuple[dict[str, Any], ...]) -> list[dict[str, Any]]:
    """Rows with floats by their repr (bit for bit; NaN equal to NaN)."""
    return [{k: repr(v) if isinstance(v, float) else v for k, v in r.items()} for r in rows]


def _csv_keys(path: Path) -> list[tuple[int, str]]:
    lines = path.read_text().splitlines()[1:]
    return [(int(line.split(",")[0]), line.split(",")[1]) for line in lines]


@pytest.fixture(scope="module")
def cluster() -> Iterator[str]:
    """An in-process LocalCluster (one worker, two threads): its scheduler address."""
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
    ) as c:
        yield c.scheduler_address


@pytest.fixture(scope="module")
def local_rows() -> list[dict[str, Any]]:
    """The reference: the same campaign in this process."""
    d = load_campaign("cm01-gaze")
    return _exact(run_campaign(d, samples=4, methods=METHODS, workers=1, progress=False).rows)


def test_local_cluster_rows_equal_the_local_run_and_resume(
    cluster: str, local_rows: list[dict[str, Any]], tmp_path: Path
) -> None:
    d, out = load_campaign("cm01-gaze"), tmp_path / "c"
    first = run_campaign(d, samples=2, methods=METHODS, scheduler=cluster, out=out, progress=False)
    assert first.computed == 2 * len(METHODS)
    full = run_campaign(d, samples=4, methods=METHODS, scheduler=cluster, out=out, progress=False)
    assert full.computed == 2 * len(METHODS)  # only the two new samples
    assert _exact(full.rows) == local_rows
    keys = _csv_keys(out / "samples.csv")
    assert sorted(keys) == sorted({(i, m) for i in range(4) for m in METHODS})
    # The local engine resumes the directory the cluster wrote, and has nothing left to do.
    again = run_campaign(d, samples=4, methods=METHODS, workers=2, out=out, progress=False)
    assert again.computed == 0 and _exact(again.rows) == local_rows


def test_cli_scheduler_option(
    cluster: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from redservo.cli import main

    out = tmp_path / "cli"
    argv = ["campaign", "cm01-gaze", "--samples", "2", "--methods", "classical,gpm"]
    assert main([*argv, "--scheduler", cluster, "--out", str(out), "-q"]) == 0
    assert "| gpm | " in capsys.readouterr().out
    assert len(_csv_keys(out / "samples.csv")) == 4
    assert main([*argv, "--scheduler", "localhost:8786", "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "tcp://HOST:8786" in err and len(err.strip().splitlines()) == 1


def test_unreachable_scheduler_and_missing_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    d = load_campaign("cm01-gaze")
    monkeypatch.setattr(engine, "CONNECT_TIMEOUT_S", 1.0)
    port = _free_port()
    start = time.monotonic()
    with pytest.raises(ConfigurationError, match="cannot reach the Dask scheduler"):
        run_campaign(d, samples=1, methods=["classical"], scheduler=f"tcp://127.0.0.1:{port}")
    assert time.monotonic() - start < 30.0
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if it were not installed
    with pytest.raises(ConfigurationError, match=r"redservo\[dask\]"):
        run_campaign(d, samples=1, methods=["classical"], scheduler="tcp://127.0.0.1:1")


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _stop(procs: list[subprocess.Popen[bytes]]) -> None:
    """SIGTERM each process group, then SIGKILL what is left after 10 s."""
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    deadline = time.monotonic() + 10.0
    for p in procs:
        try:
            p.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=10.0)


@pytest.mark.skipif(sys.platform == "win32", reason="process groups (POSIX)")
def test_real_scheduler_and_two_worker_processes(
    local_rows: list[dict[str, Any]], tmp_path: Path
) -> None:
    """``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1 (free ports): the
    campaign's rows are those of the local run, and both workers ran jobs."""
    dask = Path(sys.executable).with_name("dask")
    if not dask.exists():
        pytest.skip("the dask command is not installed next to this interpreter")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    log = tmp_path / "dask.log"
    procs: list[subprocess.Popen[bytes]] = []
    try:
        with open(log, "wb") as fh:
            opts: dict[str, Any] = {"stdout": fh, "stderr": fh, "start_new_session": True}
            scheduler = [str(dask), "scheduler", "--host", "127.0.0.1", "--port", str(port)]
            procs.append(subprocess.Popen([*scheduler, "--no-dashboard"], **opts))
            for name in ("w0", "w1"):
                worker = [str(dask), "worker", address, "--nthreads", "1", "--no-nanny"]
                more = ["--host", "127.0.0.1", "--name", name, "--no-dashboard"]
                procs.append(subprocess.Popen([*worker, *more, "--death-timeout", "60"], **opts))
        with distributed.Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
            done: dict[str, Any] = {}

            def campaign() -> None:
                try:
                    done["res"] = run_campaign(
                        load_campaign("cm01-gaze"), samples=4, methods=METHODS,
                        scheduler=address, out=tmp_path / "c", progress=False,
                    )  # fmt: skip
                except BaseException as exc:  # reported below
                    done["exc"] = exc

            thread = threading.Thread(target=campaign, daemon=True)
            thread.start()
            thread.join(timeout=300.0)  # bounded: the finally below stops the cluster
            assert not thread.is_alive(), "the campaign did not finish within 300 s"
            assert "exc" not in done, done.get("exc")
            res = done["res"]
            ran = client.run(lambda: len(engine._DEFS))  # a definition cached = jobs ran there
        assert _exact(res.rows) == local_rows, log.read_text()[-2000:]
        assert sorted(ran.values()) == [1, 1], ran
    finally:
        _stop(procs)
    assert all(p.poll() is not None for p in procs)
