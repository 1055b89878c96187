"""One BLAS thread while compiled kernels run (campaigns, the simulation and servo loops).

The compiled kernels hand their small products and factorizations to the BLAS and LAPACK
that numpy and scipy load (OpenBLAS in the wheels). That library starts a pool of threads,
one per core, and splits a product among them once it is large enough (at n = 100 joints
the (6, n) products of a step are): on an idle machine that costs little, on a loaded one
the threads spin waiting for each other and a 50 µs step takes milliseconds of CPU
(benchmarks/blas_threads.py measures it). A control step is far too small to gain from
threads, and campaigns run one process per core already, so:

* :func:`one_blas_thread` is a context manager that limits every loaded BLAS (and OpenMP)
  library to one thread while it is open, and restores the previous limits when the
  outermost one closes (it nests and costs a counter increment when already open). The
  campaign's jobs (:func:`redservo.campaign.task.run_job`, in this process, a local
  worker or a Dask worker), :func:`redservo.simulation.simulate` and the hardware servo
  loop run inside it;
* :func:`pin_process` limits a whole worker process, for its life (the local campaign
  pool's initializer): the libraries loaded already, and through :data:`THREAD_ENV` those
  loaded later.

Uses threadpoolctl (a dependency), which finds the libraries whatever their build.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["THREAD_ENV", "one_blas_thread", "pin_process"]

THREAD_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")
"""Environment variables read by the BLAS libraries when they load (set to 1 by
:func:`pin_process`)."""

_lock = threading.Lock()
_depth = 0
_limiter: Any = None
_controller: Any = None


def _libraries() -> Any:
    """threadpoolctl's controller of the libraries loaded, built once after numpy's and
    scipy's BLAS are (the kernels call scipy's: numba's ``np.dot`` and ``np.linalg``)."""
    global _controller
    import numpy  # noqa: F401  (its BLAS)
    import scipy.linalg.cython_blas  # noqa: F401  (the BLAS numba's kernels call)
    from threadpoolctl import ThreadpoolController

    if _controller is None:
        _controller = ThreadpoolController()
    return _controller


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Limit the BLAS and OpenMP libraries to one thread inside the ``with`` block (module
    docstring); re-entrant, process-wide (the libraries' limits are)."""
    global _depth, _limiter
    with _lock:
        if _depth == 0:
            _limiter = _libraries().limit(limits=1)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                _limiter.restore_original_limits()
                _limiter = None


def pin_process() -> None:
    """Limit this process's BLAS and OpenMP libraries to one thread for good (a worker
    process): :data:`THREAD_ENV` for the libraries loaded later, threadpoolctl for those
    loaded already."""
    for name in THREAD_ENV:
        os.environ[name] = "1"
    _libraries().limit(limits=1)
