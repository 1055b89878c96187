"""The argument parser of the ``redservo`` command line, one function per command group.

:func:`build_parser` assembles the parser; each ``_add_*`` function adds one command (its
options, help text and the function that runs it, :mod:`redservo.cli.commands`;
``plot``/``replay``/``view``/``animate`` come from :func:`redservo.cli.tools.register`).
Commands that run control steps set ``compiles=True``: :func:`redservo.cli.entry.main` then says
once when the numba kernels are being compiled (:mod:`redservo.bench.warmup`).
"""

from __future__ import annotations

import argparse
from typing import Any

from redservo.cli import commands as cmd
from redservo.cli.common import Parser, add_figure_options, int_in, method_list, method_name
from redservo.experiment.camera_presets import add_camera_option

__all__ = ["EPILOG", "build_parser"]

EPILOG = "Scenario format: docs/scenarios.md; campaigns: docs/campaigns.md. Names: redservo list."

_SET_HELP = (
    "override a scenario key, e.g. --set control.lam=0.8 --set control.options.alpha=2 "
    "(values are TOML; repeatable)"
)


def build_parser() -> argparse.ArgumentParser:
    """The ``redservo`` parser with every command."""
    from redservo._version import __version__
    from redservo.cli.tools import register

    p = Parser(
        prog="redservo",
        description="Redundancy-based joint-limit avoidance for visual servoing "
        "(Chaumette & Marchand 2001, Mansard & Chaumette 2005, and baselines).",
        epilog=EPILOG,
    )
    p.add_argument("--debug", action="store_true", help="show the traceback of an error")
    p.add_argument("--version", action="version", version=f"redservo {__version__}")
    common = Parser(add_help=False)
    common.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    common.add_argument(
        "--debug",
        action="store_true",
        default=argparse.SUPPRESS,
        help="show the traceback of an error",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (_add_run, _add_compare, _add_list, _add_reproduce, _add_campaign, _add_bench):
        add(sub, common)
    _add_warmup(sub, common)
    register(sub, common, int_in)
    from redservo.cli.calibrate import register as register_calibrate

    register_calibrate(sub, common)
    from redservo.cli.servo import register as register_servo

    register_servo(sub, common)
    return p


def _add_run(sub: Any, common: argparse.ArgumentParser) -> None:
    r = sub.add_parser("run", help="run one scenario", parents=[common], epilog=EPILOG)
    r.add_argument(
        "scenario", help="a shipped scenario name (redservo list) or a path to a .toml file"
    )
    r.add_argument("--method", type=method_name, help="override the scenario's control method")
    r.add_argument("--set", action="append", metavar="KEY=VALUE", help=_SET_HELP)
    add_camera_option(r)
    r.add_argument("--out", help="output directory (default runs/SCENARIO-METHOD)")
    r.add_argument("--plot", action="store_true", help=argparse.SUPPRESS)  # now the default
    r.add_argument(
        "--video",
        metavar="FILE",
        help="also write the camera view with the measured and desired features and the error "
        "(.gif, or .mp4 when an encoder is installed; needs redservo[vision])",
    )
    add_figure_options(r)
    r.set_defaults(func=cmd.cmd_run, compiles=True)


def _add_compare(sub: Any, common: argparse.ArgumentParser) -> None:
    c = sub.add_parser(
        "compare", help="run several methods on one scenario", parents=[common], epilog=EPILOG
    )
    c.add_argument("scenario", help="a shipped scenario name or a path to a .toml file")
    c.add_argument(
        "--methods", type=method_list, required=True, help="comma-separated method names"
    )
    c.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scenario key")
    add_camera_option(c)
    c.add_argument("--out", help="output directory (default runs/SCENARIO-compare)")
    add_figure_options(c)
    c.set_defaults(func=cmd.cmd_compare, compiles=True)


def _add_list(sub: Any, common: argparse.ArgumentParser) -> None:
    ls = sub.add_parser(
        "list", help="list the shipped scenarios, campaigns and methods", parents=[common]
    )
    ls.set_defaults(func=cmd.cmd_list)


def _add_reproduce(sub: Any, common: argparse.ArgumentParser) -> None:
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
        nargs="?",
        const=20,
        default=0,
        metavar="N",
        help="also re-run every experiment on N perturbed set-ups per factor (each factor "
        "alone and all together) and report, per claim and factor, how often it holds "
        "(--robustness alone: N = 20; default: none)",
    )
    rp.add_argument(
        "--unfiltered",
        type=int,
        default=0,
        metavar="N",
        help="also run every experiment on N set-ups drawn without the filter that chose the "
        "nominal one for the papers' phenomena (wider start and target, ideal sensor) and "
        "report each claim's rate beside its nominal verdict (default: none)",
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
        help="image: also run every experiment (the cross-comparison included) with its "
        "features measured in a realistic rendered camera image (noise, blur, lighting "
        "gradient, uncorrected distortion), and report per claim whether it still holds "
        "(needs redservo[vision])",
    )
    add_camera_option(rp, reproduce=True)
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
    rp.set_defaults(func=cmd.cmd_reproduce, compiles=True)


def _add_campaign(sub: Any, common: argparse.ArgumentParser) -> None:
    from redservo.schema.campaign import MAX_SAMPLES

    cp = sub.add_parser(
        "campaign",
        help="Monte Carlo comparison of methods on random variations",
        parents=[common],
        epilog=EPILOG,
    )
    cp.add_argument("scenario", help="a shipped campaign name or a campaign .toml file")
    cp.add_argument(
        "--methods", type=method_list, help="comma-separated methods (default: the campaign's list)"
    )
    cp.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a key of the base scenario (after the campaign's overrides)",
    )
    add_camera_option(cp)
    add_figure_options(cp)
    cp.add_argument(
        "--samples", type=int_in(1, MAX_SAMPLES), default=None, help="number of random variations"
    )
    cp.add_argument(
        "--seed",
        type=int_in(0, 2**63 - 1),
        default=0,
        help="random seed (results do not depend on --workers)",
    )
    cp.add_argument(
        "--workers",
        type=int_in(1, 1024),
        default=None,
        help="parallel processes (default: all cores)",
    )
    cp.add_argument(
        "--check-reach",
        action="store_true",
        help="judge each sample's reachability again with an independent method and list the "
        "disagreements in campaign.md/campaign.json (about 1 CPU s per sample, in this process)",
    )
    _add_campaign_storage(cp)
    cp.set_defaults(func=cmd.cmd_campaign, compiles=True)


def _add_campaign_storage(cp: argparse.ArgumentParser) -> None:
    """The campaign's options on where it runs and where its rows are stored."""
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


def _add_bench(sub: Any, common: argparse.ArgumentParser) -> None:
    from redservo.cli.bench import add_bench_arguments

    b = sub.add_parser("bench", help="time the control step of every method", parents=[common])
    add_bench_arguments(b, int_in)
    b.set_defaults(func=cmd.cmd_bench, compiles=True)


def _add_warmup(sub: Any, common: argparse.ArgumentParser) -> None:
    w = sub.add_parser(
        "warmup",
        parents=[common],
        help="compile every numba kernel ahead of use (the first run otherwise pays it)",
        description="Compile the numba kernels of every method, robot, feature and compiled "
        "loop into the on-disk cache, with progress on stderr; a second run only loads them.",
    )
    w.add_argument(
        "--jobs",
        type=int_in(1, 64),
        default=1,
        help="processes compiling at once (default 1; 2 on 2 cores halves a cold warm-up)",
    )
    w.set_defaults(func=cmd.cmd_warmup)
