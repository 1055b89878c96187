"""Self-describing runs: the resolved scenario of a run, written beside its log.

:meth:`redservo.experiment.build.Experiment.run` attaches a :class:`Provenance` to its result
(the scenario table, the method and its options, the simulation options and the joint
limits actually used); :meth:`redservo.simulation.SimulationResult.save` then calls
:func:`write_run_files`, which writes into the run directory:

* ``scenario.toml`` — the **resolved** scenario: the scenario's table with the run's
  method, every option of the law (its defaults included), the simulation options used
  and every default of the schema written out, headed by the redservo version, so that
  ``redservo run RUN_DIR/scenario.toml`` re-runs it exactly even if defaults change;
* ``run.json`` — the redservo version, the method and its options, the creation time,
  and ``exact``: whether re-running ``scenario.toml`` rebuilds the very same experiment
  (start, limits, options; checked by building it), with the reasons when it does not
  (e.g. code that removed the robot's rate limits, which no scenario key expresses),
  and the controller's ``engine`` (``"compiled"``, ``"kernels"`` or ``"python"``,
  :attr:`redservo.control.Controller.engine`) with ``engine_reason``, and ``kernels``:
  ``"numba X.Y"`` (compiled) or ``"python"`` (the plain kernels, :mod:`redservo.bench.kernel_mode`);
* ``diagnostics.json`` — for each diagnostic flag raised, the iterations, the number
  attached at each and the law's first message (docs/safety.md), and the law's
  informational lines with the iteration each first appeared;
* ``files/`` — copies of the files the scenario references (a URDF and its meshes, a
  camera file), which ``scenario.toml`` names by relative paths (:mod:`redservo.runs.files`);
* ``kinematics.npz`` — the robot's camera poses, Jacobians and link poses at every logged
  configuration (:mod:`redservo.runs.kinematics`), so that the run is shown without the robot's model.

A run directory is thus self-contained: moved elsewhere, it re-runs, plots, replays, views
and animates without the original files.

A result made without an experiment (``simulate`` called directly) gets
``diagnostics.json`` only.
"""

from __future__ import annotations

import copy
import inspect
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo._version import __version__
from redservo.errors import RedservoError
from redservo.limits import JointLimits

if TYPE_CHECKING:  # pragma: no cover
    from redservo.scenario import Scenario
    from redservo.simulation import SimulationLog, SimulationResult
    from redservo.simulation.options import SimulationOptions

__all__ = ["Provenance", "resolve", "write_run_files"]

_SIM_KEYS = (
    "max_iterations",
    "tolerance",
    "stop_at_convergence",
    "min_margin",
    "noise_std",
    "seed",
    "depth_scale",
    "feedforward",
    "image_margin_px",
    "check_image",
)
"""SimulationOptions fields written as ``simulation.<same name>``."""


@dataclass(frozen=True)
class Provenance:
    """What a run was made from (small and picklable; resolved only when saved).

    Attributes:
        data: The scenario's TOML table (overrides applied, URDF paths absolute).
        source: Where the scenario came from (file, ``shipped:NAME``).
        method: The law's name.
        law_options: The law's options as given, safety options (shield, robust,
            scaling) included.
        options: The simulation options used.
        limits: The joint limits the law was given.
        q0: Start configuration (m or rad).
        rebuild: Builds the experiment of a scenario (:func:`redservo.experiment.build.build`,
            given by the experiment so that this module, which the simulation's ``save``
            imports, stays below it); :func:`resolve` rebuilds the resolved scenario with it.
        robot: The robot the run moved (its kinematics are logged when saved), or None.
    """

    data: Mapping[str, Any]
    source: str
    method: str
    law_options: Mapping[str, Any]
    options: SimulationOptions
    limits: JointLimits
    q0: FloatArray = field(repr=False)
    rebuild: Callable[[Scenario], Any] = field(repr=False)
    robot: Any = field(default=None, repr=False, compare=False)


def law_defaults(method: str) -> dict[str, Any]:
    """The keyword options of law ``method`` and their defaults (None-valued ones left out)."""
    from redservo.redundancy import law_class

    params = inspect.signature(law_class(method).__init__).parameters
    return {
        k: p.default
        for k, p in params.items()
        if p.kind is inspect.Parameter.KEYWORD_ONLY and p.default is not None
    }


def _control(table: dict[str, Any], prov: Provenance) -> None:
    from redservo.redundancy.base import SAFETY_OPTIONS
    from redservo.redundancy.gain import AdaptiveGain

    ctl = table.setdefault("control", {})
    given = dict(prov.law_options)
    for key in SAFETY_OPTIONS:
        if key in given:
            ctl[key] = given.pop(key)
    ctl["method"] = prov.method
    ctl["options"] = {**law_defaults(prov.method), **given}
    lam = prov.options.lam
    ctl.pop("lam", None)
    ctl.pop("gain", None)
    if isinstance(lam, AdaptiveGain):
        ctl["gain"] = {"zero": lam.zero, "inf": lam.inf, "slope": lam.slope}
    else:
        ctl["lam"] = float(lam)
    ctl["dt"] = float(prov.options.dt)


def _simulation(table: dict[str, Any], prov: Provenance) -> None:
    opt = prov.options
    sim = table.setdefault("simulation", {})
    for key in _SIM_KEYS:
        sim[key] = getattr(opt, key)
    sim.pop("qdot_max", None)  # the key's former name
    if opt.qdot_max is None:
        sim.pop("qdot_saturation", None)
    else:
        q = opt.qdot_max
        sim["qdot_saturation"] = [float(v) for v in q] if isinstance(q, tuple) else float(q)
    table.setdefault("robot", {})["rho"] = float(opt.rho)
    if opt.occlusion is None:
        table.pop("occlusion", None)
    else:
        o = opt.occlusion
        table["occlusion"] = {f.name: getattr(o, f.name) for f in fields(o)}


def _fill_defaults(table: dict[str, Any], source: str) -> dict[str, Any]:
    """Write out every default of the schema that the table accepts explicitly."""
    from redservo.schema import ScenarioSpec, validate

    full = validate(ScenarioSpec, table, source).model_dump(mode="python", exclude_none=True)
    out = copy.deepcopy(table)

    def accepted(candidate: dict[str, Any]) -> bool:
        try:
            validate(ScenarioSpec, candidate, source)
        except RedservoError:
            return False
        return True

    for key, value in full.items():
        if isinstance(value, dict) and key not in ("robot",):
            have = out.get(key, {})
            for sub, v in value.items():
                if sub in have:
                    continue
                trial = copy.deepcopy(out)
                trial.setdefault(key, {})[sub] = v
                if accepted(trial):
                    out = trial
        elif isinstance(value, list) and key in ("objects", "features"):
            for i, entry in enumerate(value):
                for sub, v in entry.items():
                    if sub in out[key][i] or isinstance(v, dict):
                        continue
                    trial = copy.deepcopy(out)
                    trial[key][i][sub] = v
                    if accepted(trial):
                        out = trial
    for sub in ("rho", "margin"):
        out["robot"].setdefault(sub, full["robot"][sub])
    return out


def resolve(prov: Provenance) -> tuple[dict[str, Any], list[str]]:
    """The resolved scenario table of a run, and why it would not re-run exactly (empty: exact).

    The table is checked by building it (:attr:`Provenance.rebuild`, i.e.
    :func:`redservo.experiment.build.build`) and comparing the start, the joint limits and the
    simulation options with the run's.
    """
    table = copy.deepcopy(dict(prov.data))
    _control(table, prov)
    _simulation(table, prov)
    try:
        table = _fill_defaults(table, prov.source)
    except RedservoError as exc:
        return table, [f"the resolved scenario does not validate: {exc}"]
    return table, _differences(table, prov)


def _same(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return a is None and b is None
    if isinstance(a, np.ndarray | tuple | list) or isinstance(b, np.ndarray | tuple | list):
        try:
            return bool(np.array_equal(np.asarray(a, dtype=float), np.asarray(b, dtype=float)))
        except (TypeError, ValueError):
            return False
    return bool(a == b)


def _differences(table: dict[str, Any], prov: Provenance) -> list[str]:
    from redservo.scenario import parse_scenario

    try:
        exp = prov.rebuild(parse_scenario(table, prov.source))
    except RedservoError as exc:
        return [f"the resolved scenario does not build: {exc}"]
    why = []
    if not _same(exp.q0, prov.q0):
        why.append("the start configuration differs")
    a, b = exp.limits, prov.limits
    for name in ("q_min", "q_max", "qdot_max", "qddot_max", "rho", "margin_abs"):
        if not _same(getattr(a, name), getattr(b, name)):
            what = "removed" if getattr(b, name) is None else "changed"
            why.append(f"the joint limits' {name} were {what} in code (no scenario key does it)")
    for f in fields(prov.options):
        if not _same(getattr(exp.options, f.name), getattr(prov.options, f.name)):
            why.append(f"simulation option {f.name} was set in code")
    return why


def _diagnostics(log: SimulationLog) -> dict[str, Any]:
    """Flags (iterations, values, first message) and info lines (first iteration)."""
    flags: dict[str, dict[str, Any]] = {}
    info: dict[str, int] = {}
    for i, d in enumerate(log.diagnostics):
        for ev in d.events:
            entry = flags.setdefault(
                ev.flag.label, {"iterations": [], "values": [], "first_message": ev.message}
            )
            if entry["iterations"] and entry["iterations"][-1] == i:
                continue
            entry["iterations"].append(i)
            entry["values"].append(float(ev.value) if np.isfinite(ev.value) else None)
        for line in d.info:
            info.setdefault(line, i)
    return {
        "flags": flags,
        "info": [{"first_iteration": i, "text": t} for t, i in info.items()],
    }


def write_run_files(out: Path, result: SimulationResult) -> list[Path]:
    """Write ``diagnostics.json``, and with a provenance ``scenario.toml`` and ``run.json``.

    Returns:
        The paths written.
    """
    from redservo.runs.tomlwriter import dumps

    paths = [out / "diagnostics.json"]
    paths[0].write_text(json.dumps(_diagnostics(result.log), indent=1) + "\n")
    prov: Provenance | None = getattr(result, "provenance", None)
    if prov is None:
        return paths
    from redservo.runs.files import bundle_files

    table, why = resolve(prov)
    files = bundle_files(out, table)  # copies; the table now names them relatively
    if prov.robot is not None:
        from redservo.runs.kinematics import KINEMATICS_FILE, write_kinematics

        write_kinematics(out, prov.robot, result.log.q)
        paths.append(out / KINEMATICS_FILE)
    header = (
        f"Resolved scenario of a run written by redservo {__version__} "
        f"({datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')}).\n"
        f"From {prov.source}, method {prov.method!r}; every option and default written out.\n"
        + (
            "Re-run it exactly: redservo run THIS_FILE"
            if not why
            else "Not an exact re-run: " + "; ".join(why)
        )
    )
    (out / "scenario.toml").write_text(dumps(table, header=header), encoding="utf-8")
    meta = {
        "redservo": __version__,
        "written": datetime.now(UTC).isoformat(),
        "scenario": table.get("name") or prov.source,
        "source": prov.source,
        "method": prov.method,
        "law_options": table["control"]["options"],
        "exact": not why,
        "not_exact_because": why,
        "engine": result.engine,
        "engine_reason": result.engine_reason,
        "kernels": _kernels(),
        "files": files,
    }
    (out / "run.json").write_text(json.dumps(meta, indent=2, default=_json_default) + "\n")
    return [*paths, out / "scenario.toml", out / "run.json", *(out / f for f in files["copied"])]


def _kernels() -> str:
    """How the kernels ran: ``"numba X.Y"`` (compiled) or ``"python"`` (plain functions,
    :mod:`redservo.bench.kernel_mode`)."""
    from redservo.kernels._jit import numba_version

    version = numba_version()
    return "python" if version is None else f"numba {version}"


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)
