"""The ``redservo`` commands that work on saved results (their options shared with the other
commands are in :mod:`redservo.cli.common`).

    redservo plot PATH [--out DIR] [--format png,pdf,svg]
    redservo replay CAMPAIGN_DIR --sample K --method M [--new] [--out DIR] [--format ...] [--no-plot]
    redservo view PATH [--method M] [--port P] [--host H] [--frames N]
    redservo animate PATH --out run.gif|run.mp4 [--method M] [--fps F] [--frames N]

``PATH`` is a run directory (``redservo run``/``replay``), a comparison or reproduction
directory (``--method`` picks a run, default the first), or for ``plot`` also a campaign
directory (any other folder is refused, nothing written into it). Registered by :func:`register` into the parser (:mod:`redservo.cli.parser`); every
command imports what it needs when it runs (the command line starts fast).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from redservo.cli.common import add_figure_options, figures, method_name, summary_line, warn

__all__ = ["print_list", "register", "reproduce_lines"]

_PATH_HELP = "a run directory, or a comparison/reproduction directory (then --method picks the run)"


def _matplotlib() -> bool:
    import importlib.util

    return importlib.util.find_spec("matplotlib") is not None


def print_list(quiet: bool) -> None:
    """``redservo list``: scenarios, campaigns, robots, methods and experiments (``-q``: names)."""
    from redservo.campaign import shipped_campaigns
    from redservo.redundancy import METHOD_DESCRIPTIONS
    from redservo.robots import ROBOTS
    from redservo.robots.mjcf import SHIPPED_MJCFS
    from redservo.robots.urdf import SHIPPED_URDFS
    from redservo.scenario import shipped_scenarios

    robots = {name: _robot_line(name) for name in ROBOTS}
    groups: list[tuple[str, dict[str, str]]] = [
        ("Scenarios (redservo run NAME)", shipped_scenarios()),
        ("Campaigns (redservo campaign NAME)", shipped_campaigns()),
        ("Robots (robot.model in a scenario)", robots),
        (
            "URDF robots (robot.urdf in a scenario; needs redservo[urdf])",
            {name: _urdf_line(name) for name in SHIPPED_URDFS},
        ),
        (
            'MJCF robots (robot.kind = "mjcf", robot.file in a scenario; needs redservo[mujoco])',
            {name: _mjcf_line(name) for name in SHIPPED_MJCFS},
        ),
        ("Methods (--method NAME)", dict(METHOD_DESCRIPTIONS)),
        ("Experiments (redservo reproduce --only ID)", _experiments()),
    ]
    for i, (title, items) in enumerate(groups):
        if quiet:
            for name in items:
                print(name)
            continue
        print(("\n" if i else "") + title + ":")
        for name, desc in items.items():
            print(f"  {name:28s} {desc}")


def _robot_line(name: str) -> str:
    from redservo.robots import make_robot

    robot = make_robot(name)
    doc = (type(robot).__doc__ or "").strip().splitlines()[0].rstrip(".")
    return f"{doc} ({robot.n} joints)"


def _urdf_line(name: str) -> str:
    """A shipped URDF: its robot name, movable joints and the shipped scenarios that use it
    (read without Pinocchio)."""
    import tomllib
    from importlib import resources

    from redservo.robots.urdf import shipped_urdf
    from redservo.robots.urdf_parse import read_urdf

    tree = read_urdf(shipped_urdf(name))
    movable = sum(1 for j in tree.joints.values() if j.movable)
    users = []
    for entry in sorted(resources.files("redservo").joinpath("scenarios").iterdir(), key=str):
        if entry.name.endswith(".toml"):
            robot = tomllib.loads(entry.read_text(encoding="utf-8")).get("robot", {})
            if str(robot.get("urdf", "")).lower() == name:
                users.append(entry.name[:-5])
    used = f"; scenarios: {', '.join(users)}" if users else ""
    return f"{tree.name}, {movable} movable joints{used}"


def _mjcf_line(name: str) -> str:
    """A shipped MJCF: its model name, joints and the shipped scenarios that use it (read
    without MuJoCo)."""
    import tomllib
    import xml.etree.ElementTree as ET
    from importlib import resources

    from redservo.robots.mjcf import shipped_mjcf

    root = ET.parse(shipped_mjcf(name)).getroot()
    joints = len(root.findall(".//worldbody//joint"))
    users = []
    for entry in sorted(resources.files("redservo").joinpath("scenarios").iterdir(), key=str):
        if entry.name.endswith(".toml"):
            robot = tomllib.loads(entry.read_text(encoding="utf-8")).get("robot", {})
            if robot.get("kind") == "mjcf" and str(robot.get("file", "")).lower() == name:
                users.append(entry.name[:-5])
    used = f"; scenarios: {', '.join(users)}" if users else ""
    return f"MuJoCo Menagerie's {root.get('model')}, trimmed, {joints} joints{used}"


def _experiments() -> dict[str, str]:
    from redservo.reproduction import experiments

    return {k: f"{s.title} ({s.paper})" for k, s in experiments().items()}


def reproduce_lines(report: dict[str, Any], out: Path) -> list[str]:
    """The console summary of ``redservo reproduce``: the count, each claim not reproduced
    (experiment id and claim), and where the report is."""
    claims = [(e["id"], c) for e in report["experiments"] for c in e["claims"]]
    failed = [(i, c) for i, c in claims if not c["reproduced"]]
    lines = [f"reproduced {len(claims) - len(failed)}/{len(claims)} claims"]
    if failed:
        lines.append(f"not reproduced ({len(failed)}):")
        lines += [f"  - [{i}] {' '.join(str(c['claim']).split())}" for i, c in failed]
    lines.append(f"details, evidence and figures: {out / 'report.md'} (and report.json)")
    return lines


# --------------------------------------------------------------------------- commands


def _cmd_plot(args: argparse.Namespace) -> int:
    from redservo.runs.replot import kind_of, replot

    kind = kind_of(Path(args.path))  # refuses any other folder before anything is written
    if not _matplotlib():
        raise ImportError("figures need matplotlib: pip install 'redservo[plot]'")
    with figures(args):
        paths = replot(args.path, out=args.out)
    where = f" into {args.out}" if args.out else ""
    print(f"re-drew the figures of the {kind} {args.path}{where}: {len(paths)} file(s)")
    for p in paths:
        print(f"  {p}")
    return 0


def _cmd_replay(args: argparse.Namespace) -> int:
    from redservo.runs.replay import replay_sample

    r = replay_sample(args.path, args.sample, args.method, out=args.out, new=args.new)
    if r.row is None and args.new:
        print(
            f"sample {args.sample} is not in the campaign: ran it as a new sample drawn from "
            "the campaign's definition and seed (--new)",
            file=sys.stderr,
        )
    with figures(args) as wanted:
        if wanted and _matplotlib():
            from redservo.plots import figures as plots

            plots.run_figures(r.result, r.experiment, r.out)
    print(summary_line(f"sample {args.sample} [{args.method}]", r.result.summary))
    warn(r.result.summary)
    if r.matches is False:
        from redservo.records.verdict import outcome_text

        row = r.row or {}
        print(
            f"warning: the stored row says {outcome_text(row)} after {row.get('iterations')} "
            "iterations: the campaign was run with another redservo version or settings",
            file=sys.stderr,
        )
    elif r.matches:
        print("matches the campaign's stored row (outcome and iterations)")
    print(f"wrote {r.out} (re-run it: redservo run {r.out / 'scenario.toml'})")
    return 0


def _cmd_view(args: argparse.Namespace) -> int:
    from redservo.viewer import pick_run
    from redservo.viewer.playback import Playback
    from redservo.viewer.server import serve

    run = pick_run(args.path, args.method)
    pb = Playback(run)
    with contextlib.redirect_stdout(sys.stderr):  # viser prints a banner
        session = serve(pb, host=args.host, port=args.port, max_frames=args.frames, block=False)
    print(f"viewing {run.path} at {session.url} (Ctrl-C to stop)", flush=True)
    try:
        session.stopped.wait()
    except KeyboardInterrupt:
        pass
    finally:
        session.stop()
    return 0


def _cmd_animate(args: argparse.Namespace) -> int:
    from redservo.viewer import pick_run
    from redservo.viewer.animate import write_animation
    from redservo.viewer.playback import Playback

    if not _matplotlib():
        raise ImportError("animations need matplotlib: pip install 'redservo[plot]'")
    run = pick_run(args.path, args.method)
    out = write_animation(Playback(run), args.out, fps=args.fps, max_frames=args.frames)
    print(f"wrote {out} ({run.name} [{run.method}])")
    return 0


def register(sub: Any, common: argparse.ArgumentParser, int_in: Callable[..., Any]) -> None:
    """Add ``plot``, ``replay``, ``view`` and ``animate`` to the ``redservo`` subparsers."""
    pl = sub.add_parser(
        "plot",
        parents=[common],
        help="re-draw the figures of a saved run, comparison, campaign or reproduction",
    )
    pl.add_argument(
        "path",
        help="a run, comparison (every method overlaid), campaign or reproduction directory; "
        "any other folder is refused",
    )
    pl.add_argument("--out", help="write the figures into this directory (default: PATH itself)")
    pl.add_argument("--format", default="png", help="figure formats: png, pdf, svg (default png)")
    pl.set_defaults(func=_cmd_plot)

    rp = sub.add_parser("replay", parents=[common], help="re-run one sample of a campaign")
    rp.add_argument("path", help="the campaign's output directory")
    rp.add_argument("--sample", type=int_in(0, 10**9), required=True, help="sample index (0-based)")
    rp.add_argument(
        "--method", type=method_name, required=True, help="the method to run (redservo list)"
    )
    rp.add_argument(
        "--new",
        action="store_true",
        help="allow a sample index outside the campaign: run it as a new sample drawn from the "
        "campaign's definition and seed (without it such an index is refused)",
    )
    rp.add_argument("--out", help="run directory (default CAMPAIGN_DIR/replay/sample-K-METHOD)")
    add_figure_options(rp)
    rp.set_defaults(func=_cmd_replay, compiles=True)

    v = sub.add_parser("view", parents=[common], help="3-D view of a saved run in the browser")
    v.add_argument("path", help=_PATH_HELP)
    v.add_argument("--method", help="which run of a comparison or reproduction directory")
    v.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    v.add_argument("--port", type=int_in(1, 65535), default=8080, help="port (default 8080)")
    v.add_argument("--frames", type=int_in(2, 100_000), default=200, help="frames on the slider")
    v.set_defaults(func=_cmd_view)

    a = sub.add_parser(
        "animate", parents=[common], help="write a video (GIF or MP4) of a saved run"
    )
    a.add_argument("path", help=_PATH_HELP)
    a.add_argument("--out", required=True, help="output file, .gif or .mp4")
    a.add_argument("--method", help="which run of a comparison or reproduction directory")
    a.add_argument("--fps", type=float, default=12.0, help="frames per second (default 12)")
    a.add_argument("--frames", type=int_in(2, 100_000), default=120, help="number of frames")
    a.set_defaults(func=_cmd_animate)
