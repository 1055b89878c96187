"""The ``redservo`` command line.

    redservo run SCENARIO [--method NAME] [--set key=value ...] [--out DIR]
    redservo compare SCENARIO --methods a,b,c [--set ...] [--out DIR]
    redservo list [-q]
    redservo reproduce [--out DIR] [--only ID[,ID]] [--fast] [--robustness N] [--seed S]
                       [--workers K] [--no-pixel-noise] [--sensor ideal|image]
    redservo campaign CAMPAIGN [--methods a,b] [--set ...] [--samples N] [--seed S]
                      [--workers K | --scheduler tcp://HOST:PORT] [--out DIR] [--wait] [--repair]
    redservo bench [--repeat N]
    redservo plot | replay | view | animate PATH ...   (redservo.cli_tools)

Commands that write figures take ``--format png,pdf,svg`` and ``--no-plot``; ``--version``
prints the version.

Exit codes: 0 on success (a run that ends in ``joint_limit`` is a result, not an error);
2 on bad input (unknown scenario, method or key, malformed or absurd file, bad option, a
missing optional extra, an output directory that cannot be written or is in use), printed
as one line ``redservo: error: FILE: key 'KEY': ...``; 1 on an unexpected internal error
(a bug: ``--debug`` shows the traceback to report); 130 when interrupted. Diagnostic flags
raised during a run are printed as ``warning:`` lines on stderr, one per flag with its
count and first iteration. Joints and iterations are numbered from 0 everywhere.
"""

from __future__ import annotations

import argparse
import json
import sys
import traceback
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from redservo.errors import RedservoError

__all__ = ["main"]

_EPILOG = "Scenario format: docs/scenarios.md; campaigns: docs/campaigns.md. Names: redservo list."

_EXTRAS = {
    "matplotlib": "plot",
    "tqdm": "progress",
    "qpsolvers": "qp",
    "daqp": "qp",
    "pinocchio": "urdf",
    "cv2": "vision",
    "numba": "fast",
    "distributed": "dask",
    "dask": "dask",
    "viser": "viewer",
    "imageio": "viewer",
    "PIL": "viewer",
    "pyarrow": "parquet",
}
"""Optional imports and the extra that installs them (pyproject.toml)."""


class _UsageError(Exception):
    """A command-line usage error (reported in one line, exit code 2)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{self.prog}: {message} (see '{self.prog} --help')")


def _int_in(lo: int, hi: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be in [{lo}, {hi}], got {value}")
        return value

    parse.__name__ = "integer"
    return parse


def _require(module: str, what: str) -> None:
    """Fail early, in one line, when an optional dependency is missing."""
    import importlib.util

    try:
        found = importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        found = False
    if not found:
        raise ImportError(f"{what} need {module}: pip install 'redservo[{_EXTRAS[module]}]'")


def _progress(
    total: int, desc: str, enabled: bool
) -> tuple[Callable[[int], None], Callable[[], None]]:
    """Return (update, close) for a progress bar on stderr (tqdm if installed)."""
    if not enabled or not sys.stderr.isatty():
        return (lambda _i: None), (lambda: None)
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is an optional extra
        return (lambda _i: None), (lambda: None)
    bar = tqdm(total=total, desc=desc, unit="it", leave=False, file=sys.stderr)

    def update(i: int) -> None:
        bar.n = i + 1
        if i % 25 == 0:
            bar.refresh()

    return update, bar.close


def _summary_line(name: str, summary: Mapping[str, Any], joints: Sequence[str] = ()) -> str:
    """One line per run; joints and iterations numbered from 0 (README, Conventions)."""
    hit = summary["limit_hit"]
    hit_s = ""
    if hit:
        j = int(hit["axis"])
        label = f" {joints[j]!r}" if j < len(joints) else ""
        hit_s = f" (joint {j}{label} at iteration {hit['iteration']})"
    cam = summary["max_camera_speed"]
    return (
        f"{name}: {summary['outcome']}{hit_s} after {summary['iterations']} iterations, "
        f"final |e| = {summary['final_error_norm']:.3g}, min margin = {summary['min_margin']:.3f}, "
        f"max camera speed = {cam['translation']:.3g} m/s / {cam['rotation']:.3g} rad/s, "
        f"discontinuity = {summary['discontinuity']:.3g}" + _safety_text(summary)
    )


def _safety_text(summary: Mapping[str, Any]) -> str:
    """The safety part of the summary line (docs/safety.md): rates, success, shield."""
    if "success" not in summary:
        return ""
    ratio = summary.get("peak_velocity_ratio")
    text = f", peak |q̇|/limit = {ratio:.2f}" if ratio is not None else ""
    text += f", {'success' if summary['success'] else 'no success'}"
    if summary.get("shield_activations"):
        text += f" (the shield acted at {summary['shield_activations']} step(s))"
    return text


def _warn(summary: Any, prefix: str = "") -> None:
    """Print one ``warning:`` line per diagnostic flag raised in a run (stderr)."""
    from redservo.simulation import flag_warnings

    for line in flag_warnings(summary):
        print(f"warning: {prefix}{line}", file=sys.stderr)


def _cmd_run(args: argparse.Namespace) -> int:
    from redservo.experiment import build
    from redservo.scenario import apply_overrides, load_scenario

    sc = load_scenario(args.scenario)
    sets = list(args.set or [])
    if args.method:
        sets.append(f'control.method="{args.method}"')
    if sets:
        sc = apply_overrides(sc, sets)
    exp = build(sc)
    update, close = _progress(exp.options.max_iterations, sc.name, not args.quiet)
    try:
        result = exp.run(progress=update)
    finally:
        close()
    out = Path(args.out or Path("runs") / f"{sc.name}-{sc.method}")
    result.save(out, extra={"scenario": sc.name, "source": sc.source, "method": sc.method})
    figs = _figures(args, lambda: _plots().run_figures(result, exp, out))
    print(_summary_line(f"{sc.name} [{sc.method}]", result.summary, exp.robot.joint_names))
    _warn(result.summary)
    if args.video:
        from redservo.vision.runvideo import run_video

        print(f"wrote {run_video(exp, result, args.video)} (camera view, features, error)")
    print(
        f"wrote {out}/: scenario.toml, summary.json, log.npz, log.csv, diagnostics.json"
        + (f" and {figs} figure(s)" if figs else "")
    )
    return 0


def _plots() -> Any:
    from redservo import plots

    return plots


def _figures(args: argparse.Namespace, draw: Callable[[], list[Path]]) -> int:
    """Draw figures in ``--format`` unless ``--no-plot``; without matplotlib say so on
    stderr (the numbers are the result). Returns the number of figures."""
    import importlib.util

    from redservo.cli_tools import figures

    with figures(args) as wanted:
        if not wanted:
            return 0
        if importlib.util.find_spec("matplotlib") is None:
            print("figures skipped: pip install 'redservo[plot]'", file=sys.stderr)
            return 0
        return len(draw())


def _cmd_compare(args: argparse.Namespace) -> int:
    from redservo.experiment import build
    from redservo.redundancy import law_class
    from redservo.scenario import apply_overrides, load_scenario

    sc = load_scenario(args.scenario)
    if args.set:
        sc = apply_overrides(sc, list(args.set))
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    if not methods:
        raise _UsageError("redservo compare: --methods: give at least one method name")
    for m in methods:
        law_class(m)  # unknown names fail before anything runs
    exp = build(sc)
    out = Path(args.out or Path("runs") / f"{sc.name}-compare")
    results = {}
    for m in methods:
        update, close = _progress(exp.options.max_iterations, m, not args.quiet)
        try:
            results[m] = exp.run(method=m, progress=update)
        finally:
            close()
        results[m].save(out / m, extra={"scenario": sc.name, "method": m})
        print(_summary_line(m, results[m].summary, exp.robot.joint_names))
        _warn(results[m].summary, f"{m}: ")
    from redservo.report import summary_table

    rows = {m: r.summary.to_dict() for m, r in results.items()}
    (out / "compare.json").write_text(json.dumps({"scenario": sc.name, "methods": rows}, indent=2))
    (out / "compare.md").write_text(f"# {sc.name}\n\n" + summary_table(rows) + "\n")
    figs = _figures(args, lambda: _plots().compare_figures(results, exp, out))
    print(
        f"wrote {out}/compare.md, compare.json, one run directory per method"
        + (f" and {figs} figure(s)" if figs else "")
    )
    return 0


def _cmd_list(args: argparse.Namespace) -> int:
    from redservo.cli_tools import print_list

    print_list(args.quiet)
    return 0


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from redservo.cli_tools import figures
    from redservo.reproduction import reproduce
    from redservo.reproduction.report import console_summary

    _require("matplotlib", "the reproduction's figures")
    with figures(args):
        report = reproduce(
            Path(args.out),
            only=args.only,
            fast=args.fast,
            progress=not args.quiet,
            robustness=args.robustness,
            seed=args.seed,
            workers=args.workers,
            pixel_noise=False if args.no_pixel_noise else None,
            sensor=args.sensor,
        )
    print("\n".join(console_summary(report, Path(args.out))))
    return 0


def _cmd_campaign(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from redservo.campaign import load_campaign, run_campaign
    from redservo.cli_tools import figures
    from redservo.scenario import apply_overrides

    methods = [m.strip() for m in args.methods.split(",") if m.strip()] if args.methods else None
    default_out = Path("runs") / f"campaign-{Path(args.scenario).stem}-seed{args.seed}"
    defn = load_campaign(args.scenario)
    if args.set:  # on the base scenario, after the campaign's own overrides
        defn = replace(defn, scenario=apply_overrides(defn.scenario, list(args.set)))
    with figures(args):
        result = run_campaign(
            defn,
            methods=methods,
            samples=args.samples,
            seed=args.seed,
            workers=args.workers,
            out=Path(args.out or default_out),
            progress=not args.quiet,
            wait=args.wait,
            repair=args.repair,
            scheduler=args.scheduler,
        )
    print(result.markdown)
    print(
        f"wrote {result.out}/samples.csv, samples.parquet, campaign.md, campaign.json and figures"
    )
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from redservo.bench_cli import main_bench

    return main_bench(args)


def _parser() -> argparse.ArgumentParser:
    from redservo.cli_tools import add_figure_options, register
    from redservo.schema.campaign import MAX_SAMPLES

    p = _Parser(
        prog="redservo",
        description="Redundancy-based joint-limit avoidance for visual servoing "
        "(Chaumette & Marchand 2001, Mansard & Chaumette 2005, and baselines).",
        epilog=_EPILOG,
    )
    p.add_argument("--debug", action="store_true", help="show the traceback of an error")
    p.add_argument("--version", action="version", version=f"redservo {_version()}")
    common = _Parser(add_help=False)
    common.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    common.add_argument(
        "--debug",
        action="store_true",
        default=argparse.SUPPRESS,
        help="show the traceback of an error",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    r = sub.add_parser("run", help="run one scenario", parents=[common], epilog=_EPILOG)
    r.add_argument(
        "scenario", help="a shipped scenario name (redservo list) or a path to a .toml file"
    )
    r.add_argument("--method", help="override the scenario's control method")
    r.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a scenario key, e.g. --set control.lam=0.8 --set control.options.alpha=2 "
        "(values are TOML; repeatable)",
    )
    r.add_argument("--out", help="output directory (default runs/SCENARIO-METHOD)")
    r.add_argument("--plot", action="store_true", help=argparse.SUPPRESS)  # now the default
    r.add_argument(
        "--video",
        metavar="FILE",
        help="also write the camera view with the measured and desired features and the error "
        "(.gif, or .mp4 when an encoder is installed; needs redservo[vision])",
    )
    add_figure_options(r)
    r.set_defaults(func=_cmd_run)

    c = sub.add_parser(
        "compare", help="run several methods on one scenario", parents=[common], epilog=_EPILOG
    )
    c.add_argument("scenario", help="a shipped scenario name or a path to a .toml file")
    c.add_argument("--methods", required=True, help="comma-separated method names")
    c.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scenario key")
    c.add_argument("--out", help="output directory (default runs/SCENARIO-compare)")
    add_figure_options(c)
    c.set_defaults(func=_cmd_compare)

    ls = sub.add_parser(
        "list", help="list the shipped scenarios, campaigns and methods", parents=[common]
    )
    ls.set_defaults(func=_cmd_list)

    rp = sub.add_parser(
        "reproduce",
        parents=[common],
        help="run every experiment of both papers; write figures, report.md and report.json",
    )
    rp.add_argument("--out", default="out", help="output directory (default out/)")
    rp.add_argument("--only", help="run only these experiment ids, comma-separated (see report.md)")
    rp.add_argument("--fast", action="store_true", help="coarser, quicker version (for tests)")
    rp.add_argument(
        "--robustness",
        type=int,
        default=0,
        metavar="N",
        help="also re-run every experiment on N perturbed set-ups and report, per claim, how "
        "often it holds (default 0: none)",
    )
    rp.add_argument("--seed", type=int, default=0, help="seed of the perturbed set-ups (default 0)")
    rp.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="K",
        help="processes of the robustness sweep (default: the number of cores)",
    )
    rp.add_argument(
        "--sensor",
        choices=("ideal", "image"),
        default="ideal",
        help="image: also run every experiment with its features measured in the rendered "
        "camera image, and report per claim whether it still holds (needs redservo[vision])",
    )
    rp.add_argument(
        "--no-pixel-noise",
        action="store_true",
        help="robustness: keep the ideal feature sensor (default: a noisy rendered image when "
        "OpenCV is installed)",
    )
    rp.add_argument(
        "--format",
        default="svg,png",
        help="figure formats among png (300 dpi), pdf, svg; the report links the first "
        "(default svg,png: vector for the report)",
    )
    rp.set_defaults(func=_cmd_reproduce)

    cp = sub.add_parser(
        "campaign",
        help="Monte Carlo comparison of methods on random variations",
        parents=[common],
        epilog=_EPILOG,
    )
    cp.add_argument("scenario", help="a shipped campaign name or a campaign .toml file")
    cp.add_argument("--methods", help="comma-separated methods (default: the campaign's list)")
    cp.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a key of the base scenario (after the campaign's overrides)",
    )
    add_figure_options(cp)
    cp.add_argument(
        "--samples", type=_int_in(1, MAX_SAMPLES), default=None, help="number of random variations"
    )
    cp.add_argument(
        "--seed",
        type=_int_in(0, 2**63 - 1),
        default=0,
        help="random seed (results do not depend on --workers)",
    )
    cp.add_argument(
        "--workers",
        type=_int_in(1, 1024),
        default=None,
        help="parallel processes (default: all cores)",
    )
    cp.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run the samples on the Dask cluster of this scheduler instead of local "
        "processes (pip install 'redservo[dask]'; docs/scaling.md); this process stores the rows",
    )
    cp.add_argument(
        "--out",
        help="output directory (default runs/campaign-NAME-seedS); finished samples are "
        "stored there and reused by a rerun",
    )
    cp.add_argument(
        "--wait", action="store_true", help="wait while another campaign writes to --out"
    )
    cp.add_argument(
        "--repair",
        action="store_true",
        help="rebuild a damaged definition.json or samples.csv from the rows that are intact",
    )
    cp.set_defaults(func=_cmd_campaign)

    b = sub.add_parser("bench", help="time the control step of every method", parents=[common])
    from redservo.bench_cli import add_bench_arguments

    add_bench_arguments(b, _int_in)
    b.set_defaults(func=_cmd_bench)
    register(sub, common, _int_in)
    return p


def _version() -> str:
    from redservo import __version__

    return __version__


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _describe(exc: BaseException) -> tuple[int, str]:
    """Exit code and one-line message of an exception that ended a command."""
    if isinstance(exc, RedservoError | _UsageError):
        return 2, _one_line(str(exc))
    if isinstance(exc, ImportError):
        text = str(exc)
        if "pip install" in text:
            return 2, _one_line(text)
        top = (exc.name or "").split(".")[0]
        if top in _EXTRAS:
            return 2, f"missing optional dependency {top}: pip install 'redservo[{_EXTRAS[top]}]'"
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return 2, _one_line(f"{where}{exc.strerror or exc}")
    if isinstance(exc, MemoryError):
        return 2, "out of memory (lower simulation.max_iterations, the samples or the workers)"
    return 1, _one_line(
        f"internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback, "
        "and please report it)"
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``redservo`` console script; returns the exit code."""
    try:
        args = _parser().parse_args(argv)
    except _UsageError as exc:
        print(f"redservo: error: {exc}", file=sys.stderr)
        return 2
    try:
        return int(args.func(args))
    except KeyboardInterrupt:  # pragma: no cover - interactive
        print("redservo: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        code, line = _describe(exc)
        if args.debug:
            traceback.print_exc()
        print(f"redservo: error: {line}", file=sys.stderr)
        return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
