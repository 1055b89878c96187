"""Campaigns on a Dask cluster (``run_campaign(scheduler=...)``, ``redservo campaign --scheduler``).

The rows are those of a local run, the client alone writes them (so a rerun resumes), and
a real ``dask scheduler`` with ``dask worker`` processes on 127.0.0.1 runs a campaign: every
row arrives with more jobs than the client's queue, when a worker is killed mid-run, and when
every worker dies the campaign stops within its timeout and resumes (docs/scaling.md).

No test sleeps to synchronise: a worker is alive when the scheduler reports it, a job is
"mid-run" when a worker preloaded to hold its jobs is reported processing one, and every wait
is bounded generously (the suite must pass while another copy loads both cores).
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

from redservo.campaign import (  # noqa: E402
    CampaignIncompleteError,
    engine,
    load_campaign,
    run_campaign,
    task,
)
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
    from redservo.cli.entry import main

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
    for bad in (0, -1.0, float("inf"), float("nan"), "60", True):
        with pytest.raises(ConfigurationError, match="worker_timeout must be a positive"):
            run_campaign(d, samples=1, scheduler=f"tcp://127.0.0.1:{port}", worker_timeout=bad)
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if it were not installed
    with pytest.raises(ConfigurationError, match=r"redservo\[dask\]"):
        run_campaign(d, samples=1, methods=["classical"], scheduler="tcp://127.0.0.1:1")


QUICK = ["classical", "gpm"]
"""Two methods of the cheap afma6-gaze-demo campaign (the process tests)."""


def _killing(monkeypatch: pytest.MonkeyPatch, log: Path, kills: int) -> None:
    """The jobs of sample 0 end in ``KilledWorker`` (what the scheduler reports when every
    worker that ran a task died) their first ``kills`` times; ``log`` counts their runs."""
    from types import SimpleNamespace

    real = engine.run_job

    def run_job(job: Any) -> Any:
        if any(i == 0 for i, _ in job.samples):
            with open(log, "a") as fh:
                fh.write("x")
            if len(log.read_text()) <= kills:
                gone = SimpleNamespace(address="tcp://127.0.0.1:1")
                raise distributed.KilledWorker("run_job-0", gone, 3)
        return real(job)

    monkeypatch.setattr(engine, "run_job", run_job)


def test_killed_worker_jobs_are_submitted_again_then_stop_loudly(
    cluster: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    d = load_campaign("afma6-gaze-demo")
    once = tmp_path / "once"
    _killing(monkeypatch, once, kills=1)
    res = run_campaign(
        d, samples=3, methods=QUICK, scheduler=cluster, out=tmp_path / "a", progress=False
    )
    assert res.complete and len(res.rows) == 6 and once.read_text() == "xx"
    err = capsys.readouterr().err
    assert "sample 0 was lost (KilledWorker: 4 workers died running it); submitting it " in err
    always = tmp_path / "always"
    _killing(monkeypatch, always, kills=100)
    with pytest.raises(CampaignIncompleteError) as info:
        run_campaign(
            d, samples=3, methods=QUICK, scheduler=cluster, out=tmp_path / "b", progress=False
        )
    assert len(always.read_text()) == engine.MAX_RESUBMITS + 1  # bounded, then loud
    assert info.value.missing == tuple((0, m) for m in QUICK)
    text = str(info.value)
    assert f"sample 0 was lost {engine.MAX_RESUBMITS + 1} times, the last time: Kill" in text
    assert "resumable" in text, text
    assert sorted(_csv_keys(tmp_path / "b" / "samples.csv")) == [
        (i, m) for i in (1, 2) for m in QUICK
    ]


def test_scaling_doc_states_the_engine_bounds() -> None:
    """docs/scaling.md states the no-worker timeout and the resubmission bound of the code."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "scaling.md").read_text()
    assert f"waits up to **{engine.NO_WORKER_TIMEOUT_S:g} s**" in text
    assert f"`MAX_RESUBMITS = {engine.MAX_RESUBMITS}`" in text


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


HOLD = '''"""Preload of a test worker: its runs of samples >= {first} wait until it is killed.

Dask may import a preload twice (its copy in the worker's directory): patch once."""
import threading

from redservo.campaign import task


def _held(real):
    never = threading.Event()

    def _run_task(t):
        if t.sample >= {first}:
            never.wait()
        return real(t)

    _run_task.held = True
    return _run_task


if not getattr(task._run_task, "held", False):
    task._run_task = _held(task._run_task)
'''


def _until(what: str, ready: Any, bound: float = 180.0, run: _Bounded | None = None) -> None:
    """Wait (bounded, generous: the machine may be loaded) until ``ready()`` is true; fail
    at once if the campaign ``run`` ended meanwhile."""
    deadline = time.monotonic() + bound
    while not ready():
        assert time.monotonic() < deadline, f"{what}: not within {bound:g} s"
        if run is not None and not run.thread.is_alive():
            raise AssertionError(f"the campaign ended before {what}: {run.exc!r}")
        time.sleep(0.05)


class _Cluster:
    """``dask scheduler`` and ``dask worker`` processes (one thread each, no nanny) on
    127.0.0.1, each in its own process group; a client that sees what the scheduler sees."""

    def __init__(self, tmp_path: Path) -> None:
        self.dask = Path(sys.executable).with_name("dask")
        if not self.dask.exists():
            pytest.skip("the dask command is not installed next to this interpreter")
        self.tmp = tmp_path
        self.address = f"tcp://127.0.0.1:{_free_port()}"
        self.log = open(tmp_path / "dask.log", "wb")
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self.client: Any = None

    def _spawn(self, name: str, cmd: list[str]) -> None:
        opts: dict[str, Any] = {"stdout": self.log, "stderr": self.log, "start_new_session": True}
        self.procs[name] = subprocess.Popen([str(self.dask), *cmd, "--no-dashboard"], **opts)

    def __enter__(self) -> _Cluster:
        port = self.address.rsplit(":", 1)[1]
        try:
            self._spawn("scheduler", ["scheduler", "--host", "127.0.0.1", "--port", port])
            self.client = distributed.Client(self.address, timeout=120, set_as_default=False)
        except BaseException:
            self.__exit__()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        if self.client is not None:
            self.client.close()
        _stop(list(self.procs.values()))
        self.log.close()
        assert all(p.poll() is not None for p in self.procs.values())

    def workers(self) -> dict[str, str]:
        """Worker name -> address, as the scheduler reports them."""
        info = self.client.scheduler_info(n_workers=-1)["workers"]
        return {str(w["name"]): addr for addr, w in info.items()}

    def start_worker(self, name: str, *, hold_from: int | None = None) -> None:
        """Start a worker and wait until the scheduler reports it; with ``hold_from`` its
        runs of samples >= hold_from never end (until it is killed)."""
        cmd = ["worker", self.address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1"]
        cmd += ["--name", name, "--death-timeout", "60"]
        if hold_from is not None:
            preload = self.tmp / f"hold_{name}.py"
            preload.write_text(HOLD.format(first=hold_from))
            cmd += ["--preload", str(preload)]
        self._spawn(name, cmd)
        _until(f"worker {name} reported by the scheduler", lambda: name in self.workers())

    def kill(self, name: str) -> None:
        """SIGKILL a worker and wait until the scheduler has removed it."""
        os.killpg(self.procs[name].pid, signal.SIGKILL)
        self.procs[name].wait(timeout=60.0)
        _until(f"worker {name} removed by the scheduler", lambda: name not in self.workers())

    def processing(self, name: str) -> int:
        """Jobs the scheduler has given to worker ``name`` and not yet seen finish."""
        address = self.workers().get(name)
        return len(self.client.processing().get(address, ())) if address else 0


class _Bounded:
    """``run_campaign`` in a thread (the test waits for it with a bound, and meanwhile
    kills workers): its result or its exception."""

    def __init__(self, campaign: str = "afma6-gaze-demo", **kwargs: Any) -> None:
        self.campaign = campaign
        self.res: Any = None
        self.exc: BaseException | None = None
        self.thread = threading.Thread(target=self._run, args=(kwargs,), daemon=True)
        self.thread.start()

    def _run(self, kwargs: dict[str, Any]) -> None:
        try:
            self.res = run_campaign(load_campaign(self.campaign), progress=False, **kwargs)
        except BaseException as exc:  # reported by join
            self.exc = exc

    def join(self, bound: float = 300.0) -> Any:
        self.thread.join(timeout=bound)
        assert not self.thread.is_alive(), f"the campaign did not end within {bound:g} s"
        return self.res


def _local_quick(samples: int) -> list[dict[str, Any]]:
    d = load_campaign("afma6-gaze-demo")
    return _exact(run_campaign(d, samples=samples, methods=QUICK, workers=1, progress=False).rows)


posix = pytest.mark.skipif(sys.platform == "win32", reason="process groups (POSIX)")


@posix
def test_real_scheduler_and_two_worker_processes(
    local_rows: list[dict[str, Any]], tmp_path: Path
) -> None:
    """``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1 (free ports): the
    campaign's rows are those of the local run, and both workers ran jobs."""
    with _Cluster(tmp_path) as c:
        c.start_worker("w0")
        c.start_worker("w1")
        run = _Bounded("cm01-gaze", samples=4, methods=METHODS, scheduler=c.address)
        res = run.join()
        assert run.exc is None, run.exc
        ran = c.client.run(lambda: len(task._DEFS))  # a definition cached = jobs ran there
    assert _exact(res.rows) == local_rows
    assert sorted(ran.values()) == [1, 1], ran


@posix
def test_one_worker_thread_and_more_jobs_than_the_queue(tmp_path: Path) -> None:
    """One worker of one thread: the client's queue holds 2 jobs, the campaign has 8. Every
    row arrives (the first batch once pulled a third job out of the queue and dropped it:
    252 of 256 rows for ``--samples 64``, and campaign.md said N = 64)."""
    out = tmp_path / "c"
    with _Cluster(tmp_path) as c:
        c.start_worker("w0")
        run = _Bounded(samples=8, methods=QUICK, scheduler=c.address, out=out)
        res = run.join()
        assert run.exc is None, run.exc
    assert sorted(_csv_keys(out / "samples.csv")) == [(i, m) for i in range(8) for m in QUICK]
    assert res.complete and _exact(res.rows) == _local_quick(8)
    assert "N = 8 samples per method" in (out / "campaign.md").read_text()


@posix
def test_a_worker_killed_mid_run_loses_no_row(tmp_path: Path) -> None:
    """Worker w0 holds every job it gets; once the scheduler reports it processing one, it is
    killed (SIGKILL): its jobs run on w1 and every row arrives."""
    out = tmp_path / "c"
    with _Cluster(tmp_path) as c:
        c.start_worker("w0", hold_from=0)
        c.start_worker("w1")
        run = _Bounded(samples=6, methods=QUICK, scheduler=c.address, out=out)
        _until("w0 processing a job", lambda: c.processing("w0") > 0, run=run)
        assert run.thread.is_alive()  # w0 holds a job: the campaign cannot have ended
        c.kill("w0")
        res = run.join()
        assert run.exc is None, run.exc
    assert sorted(_csv_keys(out / "samples.csv")) == [(i, m) for i in range(6) for m in QUICK]
    assert res.complete and _exact(res.rows) == _local_quick(6)


@posix
def test_every_worker_killed_stops_within_the_timeout_and_resumes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The only worker holds sample 2 and is killed once samples 0 and 1 are stored: the
    client says on stderr what it waits for, stops after ``worker_timeout`` with an error
    naming the missing samples and saying the campaign is resumable; the stored rows are
    kept, and a rerun with a new worker computes only the missing ones."""
    out, timeout = tmp_path / "c", 2.0
    csv = out / "samples.csv"
    with _Cluster(tmp_path) as c:
        c.start_worker("w0", hold_from=2)
        run = _Bounded(
            samples=4, methods=QUICK, scheduler=c.address, out=out, worker_timeout=timeout
        )
        stored = lambda: csv.exists() and len(_csv_keys(csv)) == 4  # noqa: E731
        _until("samples 0 and 1 stored", stored, run=run)
        killed = time.monotonic()
        c.kill("w0")
        run.join()
        waited = time.monotonic() - killed
        assert isinstance(run.exc, CampaignIncompleteError), run.exc
        text = str(run.exc)
        assert f"no Dask worker is connected to {c.address} for 2 s" in text, text
        assert "4 of 8 runs missing: samples 2, 3 (every method)" in text, text
        assert "resumable" in text and str(csv) in text, text
        assert timeout <= waited < timeout + 120.0, waited  # generous: a loaded machine
        assert f"waiting up to 2 s for one (start workers with `dask worker {c.address}`" in (
            capsys.readouterr().err
        )
        assert sorted(_csv_keys(csv)) == [(i, m) for i in (0, 1) for m in QUICK]
        c.start_worker("w1")
        again = _Bounded(samples=4, methods=QUICK, scheduler=c.address, out=out)
        res = again.join()
        assert again.exc is None, again.exc
    assert res.computed == 4 and res.complete
    assert _exact(res.rows) == _local_quick(4)
