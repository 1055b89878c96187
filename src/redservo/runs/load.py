"""Load a saved run: :func:`load_run` (public as ``redservo.load_run``).

A run directory (``redservo run``, each method of ``redservo compare``, each run of
``redservo reproduce``, ``redservo replay``) holds ``summary.json``, ``log.npz``,
``log.csv``, ``diagnostics.json`` and, when the run was made from a scenario, the resolved
``scenario.toml``, ``run.json``, the files it references (``files/``) and the robot's
logged kinematics (``kinematics.npz``; :mod:`redservo.runs.provenance`). :func:`load_run` reads
them into a :class:`Run`; its :attr:`Run.log` is a pandas DataFrame (``pip install
pandas``) with one row per iteration and the columns of ``log.csv`` (vectors split as
``q[0]``, ``q[1]``, ...; flags as ``flag.<label>``), and :attr:`Run.arrays` the same data
as numpy arrays. :func:`find_runs` lists the runs under a comparison or reproduction
directory. Units: s, m, rad; joints and iterations 0-based.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from redservo.experiment.build import Experiment
    from redservo.scenario import Scenario
    from redservo.simulation import SimulationLog

__all__ = ["Run", "find_runs", "is_run_dir", "load_run"]

_MARKERS = ("summary.json", "log.npz")


def is_run_dir(path: Path) -> bool:
    """True when ``path`` holds a saved run (``summary.json`` and ``log.npz``)."""
    return all((path / m).is_file() for m in _MARKERS)


@dataclass(frozen=True, eq=False)
class Run:
    """A saved run.

    Attributes:
        path: The run directory.
        summary: ``summary.json`` (:meth:`redservo.simulation.RunSummary.to_dict` plus the
            scenario, method or label it was saved with).
        arrays: The logged arrays by name (``t`` (N,) s, ``q`` (N, n), ``qdot``,
            ``camera_twist`` (N, 6), ``s``, ``e``, ``e1``, ``error_norm``, ``q_normalized``,
            ``flags`` (N, F), ...), as in :class:`redservo.simulation.SimulationLog`.
        joint_names: Joint names, 0-based order.
        feature_names: Names of the logged feature components.
        meta: ``run.json`` (redservo version, method, law options, ``exact``), or {}.
        diagnostics: ``diagnostics.json`` (flags raised, info lines), or {}.
    """

    path: Path
    summary: dict[str, Any]
    arrays: dict[str, FloatArray] = field(repr=False)
    joint_names: tuple[str, ...]
    feature_names: tuple[str, ...]
    meta: dict[str, Any] = field(default_factory=dict, repr=False)
    diagnostics: dict[str, Any] = field(default_factory=dict, repr=False)
    pair_names: tuple[str, ...] = ()
    """The collision pairs the log's ``closest_pair`` indexes (empty: none measured)."""

    @property
    def method(self) -> str:
        """The control method (from ``run.json``, else ``summary.json``)."""
        return str(self.meta.get("method") or self.summary.get("method") or "run")

    @property
    def name(self) -> str:
        """The scenario name (or the directory name)."""
        return str(self.meta.get("scenario") or self.summary.get("scenario") or self.path.name)

    @property
    def outcome(self) -> str:
        """How the run ended (``converged``, ``joint_limit``, ...)."""
        return str(self.summary.get("outcome", ""))

    @property
    def scenario_path(self) -> Path | None:
        """The resolved ``scenario.toml``, if the run has one."""
        p = self.path / "scenario.toml"
        return p if p.is_file() else None

    def __len__(self) -> int:
        return int(self.arrays["t"].shape[0])

    @cached_property
    def log(self) -> pd.DataFrame:
        """Per-iteration log: a pandas DataFrame indexed by iteration (columns of ``log.csv``).

        Raises:
            ConfigurationError: pandas is not installed.
        """
        try:
            import pandas as pd
        except ImportError:
            raise ConfigurationError(
                "Run.log is a pandas DataFrame: pip install pandas (Run.arrays holds the "
                "same data as numpy arrays)"
            ) from None
        from redservo.records.runlog import FLAG_COLUMNS

        cols: dict[str, FloatArray] = {}
        for name, arr in self.arrays.items():
            a = np.asarray(arr, dtype=float).reshape(len(self), -1)
            if name == "flags":
                cols.update({c: a[:, i] for i, c in enumerate(FLAG_COLUMNS[: a.shape[1]])})
            elif a.shape[1] == 1 and np.asarray(arr).ndim == 1:
                cols[name] = a[:, 0]
            else:
                cols.update({f"{name}[{i}]": a[:, i] for i in range(a.shape[1])})
        frame = pd.DataFrame(cols)
        frame.index.name = "iteration"
        frame.attrs.update(joint_names=list(self.joint_names), method=self.method)
        return frame

    @cached_property
    def scenario(self) -> Scenario:
        """The resolved scenario the run was made from.

        Raises:
            ConfigurationError: the run has no ``scenario.toml`` (saved by an older redservo
                or by a bare :func:`redservo.simulation.simulate`).
        """
        from redservo.scenario import load_scenario

        if self.scenario_path is None and "max_cycle_time" in self.summary:
            raise ConfigurationError(
                f"{self.path}: a servo-loop run (ServoResult.save: a rehearsal or a real arm) "
                "holds its log but not the scenario it was built from, so there is no robot, "
                "scene or camera to draw; copy that scenario's .toml into the directory as "
                "scenario.toml to view it",
                argument="path",
            )
        if self.scenario_path is None:
            raise ConfigurationError(
                f"{self.path}: no scenario.toml (the run was saved without its scenario, "
                "e.g. by an older redservo): re-run it with this version to view or replay it",
                argument="path",
            )
        return load_scenario(self.scenario_path)

    @property
    def kinematics_path(self) -> Path | None:
        """The logged kinematics ``kinematics.npz`` (:mod:`redservo.runs.kinematics`), if the run has them."""
        from redservo.runs.kinematics import KINEMATICS_FILE

        p = self.path / KINEMATICS_FILE
        return p if p.is_file() else None

    def experiment(self, *, logged: bool | None = None) -> Experiment:
        """Rebuild the experiment (robot, scene, task, camera) from :attr:`scenario`.

        Args:
            logged: True: the robot replays the run's logged kinematics
                (:class:`~redservo.runs.kinematics.LoggedRobot`: shows and plots the run, cannot
                simulate a new one); False: the scenario's own robot; None (default): the
                scenario's own robot, or the logged one when the former cannot be built here
                (e.g. a URDF robot without Pinocchio).

        Raises:
            ScenarioError: the scenario does not build (and no kinematics are logged).
        """
        from redservo.errors import RedservoError
        from redservo.experiment.build import build
        from redservo.runs.kinematics import LoggedRobot

        kin = self.kinematics_path
        if logged and kin is None:
            raise ConfigurationError(
                f"{self.path}: no kinematics.npz (saved by an older redservo): re-run it with "
                "this version",
                argument="logged",
            )
        if not logged:
            try:
                return build(self.scenario)
            except RedservoError as exc:
                robot_key = str(getattr(exc, "argument", "") or "").startswith("robot")
                if logged is False or kin is None or not robot_key:
                    raise
        assert kin is not None
        return build(self.scenario, robot=LoggedRobot(kin))

    def simulation_log(self) -> SimulationLog:
        """The log as a :class:`redservo.simulation.SimulationLog` (for the figure functions)."""
        from redservo.simulation import SimulationLog

        names = SimulationLog._ARRAYS
        kwargs: dict[str, Any] = {n: np.asarray(self.arrays[n]) for n in names if n in self.arrays}
        return SimulationLog(
            **kwargs,
            joint_names=self.joint_names,
            feature_names=self.feature_names,
            pair_names=self.pair_names,
        )


def _json(path: Path) -> dict[str, Any]:
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigurationError(f"{path}: damaged ({exc})", argument="path") from None
    return data if isinstance(data, dict) else {}


def load_run(path: str | Path) -> Run:
    """Load a saved run directory (or a file inside it).

    Args:
        path: The run directory, or its ``summary.json``, ``scenario.toml`` or ``log.npz``.

    Raises:
        ConfigurationError: ``path`` is not a run directory (the message says what it
            holds instead, e.g. a comparison: then give one of its method directories), or
            its ``log.npz`` is damaged or disagrees with itself, ``summary.json`` or the joint
            names (:mod:`redservo.records.logcheck`; the message names the file and key).
    """
    p = Path(path)
    if p.is_file():
        p = p.parent
    if not is_run_dir(p):
        inside = [r.relative_to(p).as_posix() for r in find_runs(p)] if p.is_dir() else []
        hint = f"; runs inside: {', '.join(inside[:6])}" if inside else ""
        what = "does not exist" if not p.exists() else "has no summary.json and log.npz"
        raise ConfigurationError(f"{p}: not a run directory ({what}){hint}", argument="path")
    from redservo.records.logcheck import check_log, read_log

    raw = read_log(p / "log.npz")
    names = tuple(str(s) for s in raw.pop("joint_names", np.array([])).tolist())
    features = tuple(str(s) for s in raw.pop("feature_names", np.array([])).tolist())
    raw.pop("flag_names", None)
    pairs = tuple(str(s) for s in raw.pop("pair_names", np.array([])).tolist())
    summary = _json(p / "summary.json")
    check_log(p / "log.npz", raw, summary, len(names))
    return Run(
        path=p,
        summary=summary,
        arrays={k: v.astype(float) for k, v in raw.items()},
        joint_names=names,
        feature_names=features,
        meta=_json(p / "run.json"),
        diagnostics=_json(p / "diagnostics.json"),
        pair_names=pairs,
    )


def find_runs(root: Path, *, depth: int = 3) -> list[Path]:
    """Run directories under ``root`` (itself included), sorted, at most ``depth`` levels deep."""
    if is_run_dir(root):
        return [root]
    if depth <= 0 or not root.is_dir():
        return []
    out: list[Path] = []
    for child in sorted(p for p in root.iterdir() if p.is_dir()):
        out.extend(find_runs(child, depth=depth - 1))
    return out
