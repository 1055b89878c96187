"""The ``redservo`` command line.

    redservo run SCENARIO [--method NAME] [--set key=value ...] [--out DIR]
    redservo compare SCENARIO --methods a,b,c [--set ...] [--out DIR]
    redservo list [-q]
    redservo reproduce [--out DIR] [--only ID[,ID]] [--fast] [--robustness N] [--seed S]
                       [--workers K] [--no-pixel-noise] [--sensor ideal|image]
    redservo campaign CAMPAIGN [--methods a,b] [--set ...] [--samples N] [--seed S]
                      [--workers K | --scheduler tcp://HOST:PORT] [--out DIR] [--wait] [--repair]
    redservo bench [--repeat N]
    redservo warmup
    redservo plot | replay | view | animate PATH ...   (redservo.cli.tools)

Commands that write figures take ``--format png,pdf,svg`` and ``--no-plot``; ``--version``
prints the version. The parser is :mod:`redservo.cli.parser`, the commands
:mod:`redservo.cli.commands` and :mod:`redservo.cli.tools`, what they share
:mod:`redservo.cli.common`. The first command that compiles the numba kernels says so in
one line on stderr, then its progress every 10 s while it compiles
(:mod:`redservo.bench.compile_progress`; ``redservo warmup`` compiles them all ahead).

Exit codes: 0 on success (a run that ends in ``joint_limit`` is a result, not an error);
2 on bad input (unknown scenario, method or key, malformed or absurd file, bad option, a
missing optional extra, an output directory that cannot be written or is in use), printed
as one line ``redservo: error: FILE: key 'KEY': ...``; 1 on an unexpected internal error
(a bug: ``--debug`` shows the traceback to report); 130 when interrupted. Diagnostic flags
raised during a run are printed as ``warning:`` lines on stderr, one per flag with its
count and first iteration. Joints and iterations are numbered from 0 everywhere.
"""

from __future__ import annotations

import os
import sys
import traceback
from collections.abc import Sequence

from redservo.cli.common import EXTRAS, UsageError
from redservo.cli.parser import build_parser
from redservo.errors import RedservoError

__all__ = ["main"]


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _describe(exc: BaseException) -> tuple[int, str]:
    """Exit code and one-line message of an exception that ended a command."""
    if isinstance(exc, RedservoError | UsageError):
        return 2, _one_line(str(exc))
    if isinstance(exc, ImportError):
        text = str(exc)
        if "pip install" in text:
            return 2, _one_line(text)
        top = (exc.name or "").split(".")[0]
        if top in EXTRAS:
            return 2, f"missing optional dependency {top}: pip install 'redservo[{EXTRAS[top]}]'"
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return 2, _one_line(f"{where}{exc.strerror or exc}")
    if isinstance(exc, MemoryError):
        return 2, "out of memory (lower simulation.max_iterations, the samples or the workers)"
    return 1, _one_line(
        f"internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback, "
        "and please report it)"
    )


def _kernels_for(command: str, *, quiet: bool) -> bool:
    """Choose compiled or plain kernels for ``command`` (:mod:`redservo.bench.kernel_mode`); say
    so in one line when it runs uncompiled because the cache is cold; True if compiled."""
    from redservo.bench.kernel_mode import COLD_NOTICE, choose_for_command

    mode, cold = choose_for_command(command)
    if cold and not quiet:
        print(COLD_NOTICE, file=sys.stderr)
    return mode == "compiled"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``redservo`` console script; returns the exit code."""
    try:
        args = build_parser().parse_args(argv)
    except UsageError as exc:
        print(f"redservo: error: {exc}", file=sys.stderr)
        return 2
    compiles = getattr(args, "compiles", False)
    try:
        if compiles:
            name = getattr(args.func, "__name__", "run").removeprefix("_").removeprefix("cmd_")
            compiles = _kernels_for(name, quiet=getattr(args, "quiet", False))
        if compiles:
            from redservo.bench.warmup import announce_compilation

            announce_compilation(name)
        code = int(args.func(args))
        sys.stdout.flush()  # a closed pipe is seen here, not in Python's flush at exit
        return code
    except KeyboardInterrupt:  # pragma: no cover - interactive
        print("redservo: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (`redservo list | head -1`): stop quietly, as a Unix tool
        # killed by SIGPIPE does, and keep Python's final flush from complaining.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except Exception as exc:
        code, line = _describe(exc)
        if args.debug:
            traceback.print_exc()
        if compiles:  # its closing line, if any, before the error line
            from redservo.bench.warmup import end_compilation_report

            end_compilation_report()
        print(f"redservo: error: {line}", file=sys.stderr)
        return code
    finally:
        if compiles:
            from redservo.bench.warmup import end_compilation_report

            end_compilation_report()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
