"""The scheduling and interpreter settings of a run on hardware (issue 31, loop jitter)."""

from __future__ import annotations

import gc
import os
import sys
import threading
import warnings

import pytest

from redservo.errors import ConfigurationError
from redservo.hardware.realtime import SWITCH_INTERVAL, quiet_interpreter, realtime_scheduling


def test_quiet_interpreter_freezes_the_heap_and_shortens_the_switch_interval() -> None:
    before = sys.getswitchinterval()
    with quiet_interpreter():
        assert sys.getswitchinterval() == pytest.approx(SWITCH_INTERVAL)
        assert gc.get_freeze_count() > 0  # what existed is out of every collection
    assert sys.getswitchinterval() == before and gc.get_freeze_count() == 0


@pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="no POSIX scheduling")
def test_the_loop_thread_runs_fifo_when_allowed_and_says_so_otherwise() -> None:
    before = (os.sched_getscheduler(0), os.sched_getparam(0))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with realtime_scheduling(7) as got:
            policy = os.sched_getscheduler(0)
    if got == "SCHED_FIFO 7":
        assert policy == os.SCHED_FIFO and not caught
    else:  # refused: said in the result and in one warning, never silently
        assert got.startswith("SCHED_OTHER (SCHED_FIFO 7 refused")
        assert len(caught) == 1 and "without real-time scheduling" in str(caught[0].message)
    assert (os.sched_getscheduler(0), os.sched_getparam(0)) == before
    with realtime_scheduling(0) as got:
        assert got == "SCHED_OTHER (not asked)" and os.sched_getscheduler(0) == before[0]


@pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="no POSIX scheduling")
def test_helper_threads_run_one_level_below_the_loop_and_are_restored() -> None:
    done = threading.Event()
    helper = threading.Thread(target=done.wait, args=(60.0,))
    helper.start()
    tid = helper.native_id
    assert tid is not None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            with realtime_scheduling(7, [tid]) as got:
                inside = (os.sched_getscheduler(tid), os.sched_getparam(tid).sched_priority)
        if got.startswith("SCHED_FIFO"):
            assert got == "SCHED_FIFO 7 (helpers 6)" and inside == (os.SCHED_FIFO, 6)
        assert os.sched_getscheduler(tid) == os.SCHED_OTHER
    finally:
        done.set()
        helper.join()


@pytest.mark.parametrize("bad", [-1, 100, 2.5, True, "50"])
def test_a_bad_priority_is_one_error_naming_it(bad: object) -> None:
    with pytest.raises(ConfigurationError, match="realtime_priority must be an integer 0-99"):
        with realtime_scheduling(bad):  # type: ignore[arg-type]
            pass
