"""Compiling the numba kernels ahead of use (``redservo warmup``), and saying so when it happens.

The kernels (:mod:`redservo.kernels`, the campaign loop) are compiled by numba on their
first call and cached on disk (docs/speed.md), so the first command after an install or an
upgrade pays a compilation of tens of seconds. Two things make that visible:

* :func:`announce_compilation` (called by the ``redservo`` commands that run control steps)
  prints one line on stderr the first time this process, or a worker forked from it,
  actually compiles a kernel: numba reports a compilation only on a cache miss (its
  ``numba:compile`` event), so nothing is printed when the cache is warm;
* :func:`warmup` runs every group of :data:`GROUPS` once (every law, every shipped
  scenario for a few iterations, the compiled steps, the compiled campaign loop), with a
  progress line per group on stderr: what it compiled and how long it took, then the total.
  A second run only loads the cache and says that it was warm.

Without numba (not installed, or ``REDSERVO_NO_NUMBA=1``) nothing is compiled: the notice is
never printed and :func:`warmup` runs the groups on the plain-Python path as a check.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import IO, Any, NamedTuple

from redservo.bench import warmup_parts as wp
from redservo.bench.compile_progress import Progress, kernel_name
from redservo.bench.warmup_parts import Note

__all__ = [
    "COLD_SECONDS",
    "GROUPS",
    "NOTICE",
    "CompileCounter",
    "Group",
    "Note",
    "WarmupReport",
    "announce_compilation",
    "end_compilation_report",
    "verdict",
    "warmup",
]

COLD_SECONDS = "60-90"
"""Wall seconds of a first ``redservo run`` on an empty cache on a 2-core machine (the
figure of the notice; docs/speed.md gives the measurement)."""

NOTICE = (
    f"redservo: compiling the numba kernels once (about {COLD_SECONDS} s on 2 cores, then "
    "cached on disk; `redservo warmup` does it ahead of use)"
)
"""The line :func:`announce_compilation` prints on the first compilation."""


class _Flag:
    """A flag set once, shared with the processes forked after it is made (campaign and
    robustness workers), so that a process tree prints the notice once; per process when
    shared memory is unavailable."""

    def __init__(self) -> None:
        self._local = False
        self._shared: Any = None
        try:
            import multiprocessing

            self._shared = multiprocessing.Value("b", 0)
        except (ImportError, OSError):  # pragma: no cover - no shared memory here
            pass

    def test_and_set(self) -> bool:
        """Set the flag; True when it was not set before (the caller is the first)."""
        if self._shared is None:
            first, self._local = not self._local, True
            return first
        with self._shared.get_lock():
            first = not self._shared.value
            self._shared.value = 1
        return bool(first)


class CompileCounter:
    """A numba event listener counting compilations (cache misses), optionally printing
    :data:`NOTICE` to ``stream`` (default: ``sys.stderr`` at the time) on the first, and
    telling ``progress`` (which prints how far along the compilations are every 10 s)."""

    def __init__(
        self,
        *,
        notice: bool = False,
        stream: IO[str] | None = None,
        progress: Progress | None = None,
    ) -> None:
        self.count = 0
        self._notice = _Flag() if notice else None
        self._stream = stream
        self.progress = progress

    def on_start(self, event: Any) -> None:
        self.count += 1
        if self._notice is not None and self._notice.test_and_set():
            stream = self._stream or sys.stderr
            print(NOTICE, file=stream, flush=True)
        if self.progress is not None:
            self.progress.on_start(kernel_name(event))

    def on_end(self, event: Any) -> None:
        if self.progress is not None:
            self.progress.on_end()

    def install(self) -> bool:
        """Listen to numba's compilations; False (nothing done) when the kernels are not
        compiled (numba missing or disabled)."""
        from redservo.kernels import compiled

        if not compiled():
            return False
        from numba.core import event

        counter = self

        class Listener(event.Listener):
            def on_start(self, ev: Any) -> None:
                counter.on_start(ev)

            def on_end(self, ev: Any) -> None:
                counter.on_end(ev)

        self._listener = Listener()
        event.register("numba:compile", self._listener)
        return True

    def uninstall(self) -> None:
        """Stop listening (after :meth:`install` returned True)."""
        from numba.core import event

        event.unregister("numba:compile", self._listener)


_ANNOUNCER: list[CompileCounter] = []


def announce_compilation(group: str = "run") -> None:
    """Print :data:`NOTICE` once on stderr when a kernel is first compiled in this process
    (or a worker it forks), then the progress of the compilations of ``group`` (the command)
    every 10 s while they go on; nothing when the cache is warm or numba is off. Idempotent."""
    if _ANNOUNCER:
        progress = _ANNOUNCER[0].progress
        if progress is not None:
            progress.set_group(group)  # this command's compilations, counted afresh
        return
    counter = CompileCounter(notice=True, progress=Progress(group))
    counter.install()
    _ANNOUNCER.append(counter)


def end_compilation_report() -> None:
    """The command is over: its compilation progress stops (its closing line now, if it
    printed progress), so nothing of it appears during the next command in this process."""
    if _ANNOUNCER and _ANNOUNCER[0].progress is not None:
        _ANNOUNCER[0].progress.finish()


# --------------------------------------------------------------------------- the groups


class Group(NamedTuple):
    """A group of kernels compiled together by running what uses them."""

    name: str
    what: str
    run: Callable[[Note], None]
    """Runs the group; its argument prints a note (e.g. a part skipped and why)."""
    parts: Callable[[], tuple[str, ...]] | None = None
    """The group's independent parts (its laws, scenarios...), which ``redservo warmup
    --jobs N`` spreads over processes (:mod:`redservo.bench.warmup_jobs`); None: one part."""
    run_part: Callable[[str, Note], None] | None = None
    """Runs one of :attr:`parts` (``run`` runs them all in order)."""
    chain: str = ""
    """The compiled chain all the group's parts share (e.g. the campaign loop's kernel, one
    signature for every campaign): ``--jobs N`` runs the group's first part, which compiles
    it, before its other parts (two workers would compile it at the same moment, each).
    Empty: parts are spread by :func:`redservo.bench.warmup_jobs.family` alone."""
    steps: bool = True
    """The group calls the step kernel (the laws' dispatch): ``--jobs N`` starts it after
    the first part, which compiles that kernel. False: it starts at once, beside it."""
    heavy: tuple[str, ...] = ()
    """Parts that compile much of their own: ``--jobs N`` hands their family out before the
    group's other families, so that none of them is left to run last, alone on one core."""


def _parted(
    name: str,
    what: str,
    parts: Callable[[], tuple[str, ...]],
    run_part: Callable[[str, Note], None],
    *,
    chain: str = "",
    steps: bool = True,
    heavy: tuple[str, ...] = (),
) -> Group:
    def run(note: Note) -> None:
        for part in parts():
            run_part(part, note)

    return Group(name, what, run, parts, run_part, chain, steps, heavy)


GROUPS: tuple[Group, ...] = (
    _parted("laws", "every method through the public API", wp.law_parts, wp.law),
    _parted(
        "scenarios",
        "every shipped scenario, 3 iterations",
        wp.scenario_parts,
        wp.scenario,
        chain="controller",
        heavy=wp.HEAVY_SCENARIOS,
    ),
    _parted(
        "compiled steps",
        "the Controller's compiled step and the campaign's iteration from Python (Afma6, Panda)",
        lambda: ("controllers",),
        wp.compiled_steps,
    ),
    _parted(
        "reachability",
        "every shipped campaign's reachability search",
        wp.campaign_parts,
        wp.search,
        chain="reach",
        steps=False,
    ),
    _parted(
        "campaign loop",
        "every shipped campaign, one sample per method",
        wp.campaign_parts,
        wp.campaign,
        chain="closed_loop",
    ),
)
"""What :func:`warmup` runs, in order."""


class WarmupReport(NamedTuple):
    """What :func:`warmup` did."""

    seconds: dict[str, float]
    """Wall seconds per group."""
    compiled: dict[str, int]
    """Kernel compilations (numba cache misses) per group; zeros without numba."""
    numba: bool
    """The kernels are compiled by numba (False: plain Python, nothing to compile)."""

    @property
    def total(self) -> float:
        """Wall seconds of the whole warm-up."""
        return sum(self.seconds.values())


def warmup(
    *, quiet: bool = False, groups: tuple[Group, ...] = GROUPS, stream: IO[str] | None = None
) -> WarmupReport:
    """Compile every kernel of ``groups`` into the on-disk cache (module docstring); one
    progress line per group on ``stream`` (default stderr; none with ``quiet``)."""
    out = stream or sys.stderr

    def say(text: str) -> None:
        if not quiet:
            print(text, file=out, flush=True)

    counter = CompileCounter(progress=None if quiet else Progress("warmup", stream=out))
    numba = counter.install()
    if not numba:
        say(
            "warmup: numba is off (not installed, or REDSERVO_NO_NUMBA is set): nothing to "
            "compile; running the groups on the plain-Python path as a check"
        )
    seconds: dict[str, float] = {}
    compiled: dict[str, int] = {}
    try:
        for i, group in enumerate(groups):
            say(f"warmup [{i + 1}/{len(groups)}] {group.name}: {group.what} ...")
            if counter.progress is not None:
                counter.progress.set_group(group.name)
            before, t0 = counter.count, time.perf_counter()
            group.run(_prefixed(say, f"  {group.name}: "))
            seconds[group.name] = time.perf_counter() - t0
            compiled[group.name] = counter.count - before
            done = f"  {group.name}: {seconds[group.name]:.1f} s"
            say(done + (f", {compiled[group.name]} kernel compilation(s)" if numba else ""))
    finally:
        if numba:
            counter.uninstall()
    report = WarmupReport(seconds, compiled, numba)
    if numba:  # every group ran: `auto` commands run compiled from now on
        from redservo.bench.kernel_mode import mark_warm

        mark_warm()
    say(verdict(report))
    return report


def _prefixed(say: Callable[[str], None], prefix: str) -> Callable[[str], None]:
    """``say`` with ``prefix`` before each line (a group's notes)."""

    def note(text: str) -> None:
        say(prefix + text)

    return note


def verdict(report: WarmupReport, wall: float | None = None) -> str:
    """The warm-up's last line: how long (``wall`` seconds, default the groups' sum) and
    how many compilations, or that the cache was warm or numba off."""
    total = sum(report.compiled.values())
    took = report.total if wall is None else wall
    if not report.numba:
        return f"warmup: done in {took:.1f} s (plain Python: nothing compiled)"
    if total == 0:
        return f"warmup: done in {took:.1f} s: the kernel cache was already warm (nothing compiled)"
    return (
        f"warmup: done in {took:.1f} s: {total} kernel compilation(s), now cached on "
        "disk; later runs load them"
    )
