"""The ``redservo`` commands that run something: run, compare, list, reproduce, campaign, bench
and warmup (the parser is :mod:`redservo.cli.parser`; the commands on saved results are in
:mod:`redservo.cli.tools`). Each command imports what it needs when it runs, so that the
command line starts fast; each returns the exit code.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from redservo.cli.common import (
    UsageError,
    draw_figures,
    engine_note,
    figures,
    progress,
    require,
    summary_line,
    warn,
)

__all__ = [
    "cmd_bench",
    "cmd_campaign",
    "cmd_compare",
    "cmd_list",
    "cmd_reproduce",
    "cmd_run",
    "cmd_warmup",
    "interrupted_campaign_line",
    "law_hint_line",
    "paper_note",
]


def _plots() -> Any:
    from redservo.plots import figures as plots

    return plots


def cmd_run(args: argparse.Namespace) -> int:
    """``redservo run``: one scenario, its run directory, figures and summary line."""
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    sc = load_scenario(args.scenario)
    sets = list(args.set or [])
    if args.method is not None:
        sets.append(f'control.method="{args.method}"')
    if sets:
        sc = apply_overrides(sc, sets)
    exp = build(sc)
    update, close = progress(exp.options.max_iterations, sc.name, not args.quiet)
    try:
        result = exp.run(progress=update)
    finally:
        close()
    out = Path(args.out or Path("runs") / f"{sc.name}-{sc.method}")
    result.save(out, extra={"scenario": sc.name, "source": sc.source, "method": sc.method})
    figs = draw_figures(args, lambda: _plots().run_figures(result, exp, out))
    print(summary_line(f"{sc.name} [{sc.method}]", result.summary, exp.robot.joint_names))
    warn(result.summary)
    engine_note(result)
    note = paper_note(sc, result.summary)
    if note:
        print(note, file=sys.stderr)
    hint = law_hint_line(exp, result.summary, args.scenario, args.set or [])
    if hint:
        print(hint, file=sys.stderr)
    if args.video:
        from redservo.vision.runvideo import run_video

        print(f"wrote {run_video(exp, result, args.video)} (camera view, features, error)")
    print(
        f"wrote {out}/: scenario.toml, summary.json, log.npz, log.csv, diagnostics.json, "
        "kinematics.npz"
        + (", files/ (copies of the files it references)" if (out / "files").is_dir() else "")
        + (f" and {figs} figure(s)" if figs else "")
    )
    return 0


def paper_note(sc: Any, summary: Any) -> str | None:
    """One line when a shipped paper scenario ran with the default safety stage and it acted
    (so the outcome need not be the paper's), with the command that runs the paper's exact
    law; None otherwise."""
    from redservo.reproduction import experiments

    acted = int(getattr(summary, "shield_activations", 0) or 0)
    if not str(sc.source).startswith("shipped:") or not acted:
        return None
    ids = [k for k, s in experiments().items() if s.scenario == sc.name and len(s.runs) > 0]
    ids = [k for k in ids if k != "cross-comparison"]
    if not ids:
        return None
    paper = sc.spec.paper or "a paper"
    return (
        f"note: {sc.name} is the set-up of {paper}; the default safety stage (control.shield) "
        f"changed the command at {acted} step(s), so this outcome need not be the paper's; the "
        f"paper's exact law: redservo reproduce --only {','.join(ids)}"
    )


def law_hint_line(exp: Any, summary: Any, scenario: str, sets: list[str]) -> str | None:
    """:func:`redservo.records.advice.law_hint` for a run that failed at a limit, with whether its
    goal is reachable within the success margin (the campaigns' inverse-kinematics search,
    run only then); None for any other run."""
    from redservo.records.advice import failed_at_a_limit, law_hint

    if not failed_at_a_limit(summary):
        return None
    from redservo.campaign.reach import reachable

    method = exp.scenario.method
    return law_hint(summary, method, scenario, sets, reachable=reachable(exp))


def compare_hint_line(exp: Any, summaries: dict[str, Any], args: argparse.Namespace) -> str | None:
    """:func:`redservo.records.advice.compare_hint` when a compared run failed at a limit (the goal's
    reachability searched only then); None otherwise."""
    from redservo.records.advice import compare_hint, failed_at_a_limit

    if not any(failed_at_a_limit(s) for s in summaries.values()):
        return None
    from redservo.campaign.reach import reachable

    sets = list(args.set or [])
    return compare_hint(summaries, args.scenario, sets, reachable=reachable(exp))


def cmd_compare(args: argparse.Namespace) -> int:
    """``redservo compare``: several methods on one scenario, a table and figures."""
    from redservo.api import check_methods
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    sc = load_scenario(args.scenario)
    if args.set:
        sc = apply_overrides(sc, list(args.set))
    methods: list[str] = args.methods
    if not methods:  # pragma: no cover - the parser's method_list never gives an empty list
        raise UsageError("--methods: give at least one method name")
    check_methods(methods)  # unknown names fail before anything runs, with "did you mean"
    exp = build(sc)
    out = Path(args.out or Path("runs") / f"{sc.name}-compare")
    results = {}
    for m in methods:
        update, close = progress(exp.options.max_iterations, m, not args.quiet)
        try:
            results[m] = exp.run(method=m, progress=update)
        finally:
            close()
        print(summary_line(m, results[m].summary, exp.robot.joint_names))
        warn(results[m].summary, f"{m}: ")
        engine_note(results[m], f"{m}: ")
    from redservo.api import write_comparison

    write_comparison(out, sc.name, results)
    hint = compare_hint_line(exp, {m: r.summary for m, r in results.items()}, args)
    if hint:
        print(hint, file=sys.stderr)
    figs = draw_figures(args, lambda: _plots().compare_figures(results, exp, out))
    print(
        f"wrote {out}/compare.md, compare.json, one run directory per method"
        + (f" and {figs} figure(s)" if figs else "")
    )
    return 0


def cmd_list(args: argparse.Namespace) -> int:
    """``redservo list``: what is shipped (``-q``: names only)."""
    from redservo.cli.tools import print_list

    print_list(args.quiet)
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    """``redservo reproduce``: every experiment of both papers, report.md and report.json."""
    from redservo.reproduction import reproduce
    from redservo.reproduction.report import console_summary

    require("matplotlib", "the reproduction's figures")
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
            unfiltered=args.unfiltered,
            camera=args.camera,
        )
    print("\n".join(console_summary(report, Path(args.out))))
    return 0


def cmd_campaign(args: argparse.Namespace) -> int:
    """``redservo campaign``: a Monte Carlo comparison stored under ``--out``."""
    from dataclasses import replace

    from redservo.campaign import load_campaign, run_campaign
    from redservo.scenario import apply_overrides

    default_out = Path("runs") / f"campaign-{Path(args.scenario).stem}-seed{args.seed}"
    out = Path(args.out or default_out)
    defn = load_campaign(args.scenario)
    if args.set:  # on the base scenario, after the campaign's own overrides
        defn = replace(defn, scenario=apply_overrides(defn.scenario, list(args.set)))
    try:
        with figures(args):
            result = run_campaign(
                defn,
                methods=args.methods,
                samples=args.samples,
                seed=args.seed,
                workers=args.workers,
                out=out,
                progress=not args.quiet,
                wait=args.wait,
                repair=args.repair,
                scheduler=args.scheduler,
            )
    except KeyboardInterrupt:
        print(interrupted_campaign_line(out), file=sys.stderr)
        return 130
    bundle_campaign_files(result.out, defn)
    print(result.markdown)
    reused = len(result.rows) - result.computed
    if reused:
        print(f"reused {reused} stored run(s) of {out / 'samples.csv'}, computed {result.computed}")
    if getattr(args, "check_reach", False):
        from redservo.campaign.reach_report import check_campaign, reach_markdown, write_reach_check

        check = check_campaign(defn, args.seed, result.rows)
        if result.out is not None:
            write_reach_check(result.out, check)
        print(reach_markdown(check))
    drawn = f" and {len(result.figures)} figure(s)" if result.figures else ""
    print(f"wrote {result.out}/samples.csv, samples.parquet, campaign.md, campaign.json{drawn}")
    return 0


def interrupted_campaign_line(out: Path) -> str:
    """What Ctrl-C in ``redservo campaign`` says: the finished runs are kept and the same
    command resumes (it then says how many stored runs it reused)."""
    return (
        f"redservo: interrupted; the runs finished so far are stored in {out / 'samples.csv'}: "
        "rerun the same command to resume (it reuses them and computes only the missing runs)"
    )


def bundle_campaign_files(out: Path | None, defn: Any) -> None:
    """Copy the files the campaign's base scenario references into ``out/files/``, so that
    ``redservo replay`` works on the directory once moved (:func:`redservo.runs.files.relocate`)."""
    import copy

    from redservo.runs.files import bundle_files

    if out is not None:
        bundle_files(Path(out), copy.deepcopy(defn.scenario.data))


def cmd_bench(args: argparse.Namespace) -> int:
    """``redservo bench``: time the control step of every method."""
    from redservo.cli.bench import main_bench

    return main_bench(args)


def cmd_warmup(args: argparse.Namespace) -> int:
    """``redservo warmup``: compile every kernel ahead of use, with progress on stderr."""
    from redservo.bench.warmup_jobs import warmup_jobs

    warmup_jobs(args.jobs, quiet=args.quiet)
    return 0
