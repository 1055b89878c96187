"""One-command reproduction of every experiment of CM01 and MC05 (``redservo reproduce``).

Each experiment lives in its own module and registers an
:class:`~redservo.reproduction.base.ExperimentSpec` whose claims are named
:class:`~redservo.reproduction.checks.Check` objects; :func:`reproduce` runs them, draws
the figures, optionally re-runs every experiment on perturbed set-ups
(:mod:`~redservo.reproduction.robustness`), and writes ``report.md`` and ``report.json``
(:mod:`~redservo.reproduction.report`).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo.errors import ConfigurationError, UnknownNameError
from redservo.reproduction.base import ExperimentSpec, Runs, RunSpec, run_experiment
from redservo.reproduction.checks import IMPL, PAPER, Check, Claim, Verdict
from redservo.reproduction.registry import experiments

if TYPE_CHECKING:  # pragma: no cover
    from redservo.experiment.build import Experiment
    from redservo.reproduction.report import ExperimentResult
    from redservo.sensors import Sensor

__all__ = [
    "IMPL",
    "PAPER",
    "Check",
    "Claim",
    "ExperimentSpec",
    "RunSpec",
    "Runs",
    "Verdict",
    "experiments",
    "reproduce",
]


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if hasattr(value, "to_dict"):
        return value.to_dict()
    return str(value)


def _select(only: str | None) -> dict[str, ExperimentSpec]:
    specs = experiments()
    if only is None:
        return specs
    wanted = [s.strip() for s in only.split(",") if s.strip()]
    unknown = [w for w in wanted if w not in specs]
    if unknown or not wanted:
        raise UnknownNameError(
            f"unknown experiment {', '.join(map(repr, unknown)) or repr(only)}; "
            f"known: {', '.join(specs)}"
        )
    return {w: specs[w] for w in wanted}


def _command(only: str | None, fast: bool, robustness: int, seed: int, unfiltered: int = 0) -> str:
    parts = ["redservo reproduce"]
    if only:
        parts.append(f"--only {only}")
    if fast:
        parts.append("--fast")
    if robustness:
        parts.append(f"--robustness {robustness}")
    if unfiltered:
        parts.append(f"--unfiltered {unfiltered}")
    if seed and (robustness or unfiltered):
        parts.append(f"--seed {seed}")
    return " ".join(parts)


def _check(
    robustness: int, workers: int | None, sensor: str, unfiltered: int = 0, camera: str = "ideal"
) -> None:
    """The options of :func:`reproduce` that no type checks."""
    for name, value in (("robustness", robustness), ("unfiltered", unfiltered)):
        if value < 0:
            raise ConfigurationError(f"{name} must be >= 0 set-ups, got {value}", argument=name)
    if workers is not None and workers < 1:
        raise ConfigurationError(f"workers must be >= 1, got {workers}", argument="workers")
    if sensor not in ("ideal", "image"):
        raise ConfigurationError(
            f"sensor must be 'ideal' or 'image', got {sensor!r}", argument="sensor"
        )
    if camera not in ("ideal", "realistic"):
        raise ConfigurationError(
            f"camera must be 'ideal' or 'realistic', got {camera!r}", argument="camera"
        )


def reproduce(
    out: Path,
    *,
    only: str | None = None,
    fast: bool = False,
    progress: bool = False,
    log: Callable[[str], None] | None = None,
    robustness: int = 0,
    seed: int = 0,
    workers: int | None = None,
    pixel_noise: bool | None = None,
    sensor: str = "ideal",
    unfiltered: int = 0,
    camera: str = "ideal",
) -> dict[str, Any]:
    """Run the experiments, write figures, ``report.md`` and ``report.json`` into ``out``.

    Args:
        out: Output directory.
        only: Run only these experiment ids (comma-separated).
        fast: Quick version (coarser; used by the tests).
        progress: Print one line per run (and per robustness set-up) on stderr.
        log: Custom progress sink (overrides ``progress``).
        robustness: Re-run every experiment on this many perturbed set-ups per factor, each
            factor alone and all together (0: none; ``redservo reproduce --robustness``
            alone means 20).
        seed: Seed of the perturbed set-ups.
        workers: Processes of the robustness sweep (default: the number of cores).
        pixel_noise: Measure the features in a noisy image in the sweep (default: when
            OpenCV is installed).
        sensor: ``"ideal"`` (default) or ``"image"``: also run every experiment (the
            cross-comparison included) with its features measured in a realistic rendered
            image (:data:`redservo.reproduction.imaging.REALISTIC`), and report per claim
            whether it still holds (needs ``redservo[vision]``).
        unfiltered: Also run every experiment on this many set-ups drawn without the
            phenomenon filter that chose the nominal one
            (:mod:`redservo.reproduction.unfiltered`; 0: none).
        camera: ``"ideal"`` (default) or ``"realistic"``: the runs through images (implied)
            come from a 30 Hz camera with 66 ms latency and an 8 ms exposure
            (:data:`redservo.experiment.camera_presets.REALISTIC_TIMING`, docs/camera-timing.md).

    Returns:
        The report as a dict (the content of ``report.json``).

    Raises:
        UnknownNameError: ``only`` names an unknown experiment.
        ConfigurationError: ``robustness``, ``unfiltered`` or ``workers`` is negative or zero
            where it must be positive.
    """
    from redservo.reproduction.report import ExperimentResult, markdown, to_json
    from redservo.reproduction.robustness import run_robustness

    _check(robustness, workers, sensor, unfiltered, camera)
    specs = _select(only)
    sink = log or ((lambda msg: print(msg, file=sys.stderr)) if progress else None)
    out.mkdir(parents=True, exist_ok=True)
    results: list[ExperimentResult] = []
    for spec in specs.values():
        runs = run_experiment(spec, fast=fast, progress=sink)
        exp_dir = out / spec.id
        figs = spec.figures(runs, exp_dir)
        for label, r in runs.results.items():
            r.save(exp_dir / "runs" / _slug(label), extra={"label": label})
        results.append(ExperimentResult(spec, runs, spec.claims(runs), figs))
    rob = None
    if robustness or unfiltered:
        nominal = {(e.spec.id, c.name): bool(c.reproduced) for e in results for c in e.claims}
        rob = run_robustness(
            list(specs.values()),
            robustness,
            seed=seed,
            fast=fast,
            workers=workers,
            pixel_noise=pixel_noise,
            nominal=nominal,
            progress=sink,
            unfiltered=unfiltered,
        )
    timed_camera = camera == "realistic"
    through = sensor == "image" or timed_camera
    image = _through_images(results, fast, sink, image_sensors(timed_camera)) if through else None
    command = _command(only, fast, robustness, seed, unfiltered)
    command += (" --camera realistic" if timed_camera else " --sensor image") if image else ""
    (out / "report.md").write_text(markdown(results, rob, out, command=command, image=image))
    report = to_json(results, rob, out, fast=fast, image=image)
    report["command"] = command
    (out / "report.json").write_text(json.dumps(report, indent=2, default=_json_default) + "\n")
    return report


def image_sensors(timed_camera: bool) -> Callable[[Experiment], Sensor]:
    """``f(experiment) -> sensor``: the realistic rendered image
    (:data:`~redservo.reproduction.imaging.REALISTIC`: noise, blur, a lighting gradient,
    uncorrected lens distortion; true depth), seen through the realistic camera's timing
    (:data:`redservo.experiment.camera_presets.REALISTIC_TIMING`) when ``timed_camera``."""
    from redservo.experiment.camera_presets import REALISTIC_TIMING
    from redservo.reproduction.imaging import REALISTIC, image_sensor
    from redservo.sensors.timing import TimedSensor

    def sensor(exp: Experiment) -> Sensor:
        found = image_sensor(exp.camera, REALISTIC, seed=0)
        return TimedSensor(found, REALISTIC_TIMING, exp.options.dt) if timed_camera else found

    return sensor


def _through_images(
    results: Sequence[ExperimentResult],
    fast: bool,
    sink: Callable[[str], None] | None,
    sensor: Callable[[Experiment], Sensor],
) -> dict[tuple[str, str], bool]:
    """Run every experiment again, the cross-comparison included, with its features measured
    by ``sensor`` (:func:`image_sensors`) with the library's detector; return the verdict of
    every claim."""

    verdicts: dict[tuple[str, str], bool] = {}
    for e in results:
        tag = (lambda msg: sink(f"{msg} [through images]")) if sink is not None else None
        runs = run_experiment(e.spec, fast=fast, progress=tag, sensor=sensor)
        for c in e.spec.claims(runs):
            verdicts[(e.spec.id, c.name)] = bool(c.reproduced)
        e.image_runs = runs
    return verdicts


def _slug(label: str) -> str:
    """A directory name for a run label (``gpm α=2`` -> ``gpm_α2``)."""
    keep = [c if c.isalnum() or c in "-_." else "_" for c in label.replace("=", "")]
    return "".join(keep).strip("_") or "run"
