"""numba's cache index keeps every entry when processes add signatures at the same time."""

from __future__ import annotations

import multiprocessing
import os
import pickle
from pathlib import Path

import pytest

numba = pytest.importorskip("numba")
fcntl = pytest.importorskip("fcntl")

from numba.core import caching  # noqa: E402

import redservo.kernels._jit  # noqa: E402  (installs the lock)
from redservo.kernels._cache_lock import LOCK_NAME  # noqa: E402

pytestmark = pytest.mark.skipif(
    not redservo.kernels._jit.COMPILED, reason="numba is off: no cache to lock"
)


def _index(tmp: Path) -> caching.IndexDataCacheFile:
    return caching.IndexDataCacheFile(str(tmp), "kern-1", "stamp")


def test_saving_an_entry_holds_the_index_lock(tmp_path: Path, monkeypatch) -> None:
    seen: list[bool] = []
    cache = _index(tmp_path)
    real = caching.IndexDataCacheFile._save_index

    def probe(self, overloads):  # another open file description cannot take the lock
        fd = os.open(tmp_path / LOCK_NAME, os.O_RDWR)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            seen.append(False)
        except BlockingIOError:
            seen.append(True)
        finally:
            os.close(fd)
        real(self, overloads)

    monkeypatch.setattr(caching.IndexDataCacheFile, "_save_index", probe)
    cache.save(("sig-a",), b"code-a")
    assert seen == [True]
    assert cache.load(("sig-a",)) == b"code-a"


def _add(tmp: str, tag: str, n: int) -> None:
    cache = _index(Path(tmp))
    for i in range(n):
        cache.save((tag, i), f"{tag}{i}".encode())


def test_two_processes_adding_signatures_keep_every_entry(tmp_path: Path) -> None:
    ctx = multiprocessing.get_context("fork")
    procs = [ctx.Process(target=_add, args=(str(tmp_path), tag, 40)) for tag in "ab"]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
        assert p.exitcode == 0
    cache = _index(tmp_path)
    for tag in "ab":
        for i in range(40):  # each entry names its own data, none lost
            assert cache.load((tag, i)) == f"{tag}{i}".encode()
    with open(tmp_path / "kern-1.nbi", "rb") as f:
        pickle.load(f)
        _, overloads = pickle.loads(f.read())
    assert len(overloads) == 80
