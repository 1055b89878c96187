"""The result of one run: its outcome, typed summary and log, and how to write it to a run
directory (``summary.json``, ``log.npz``, ``log.csv``, ``diagnostics.json``, and with a
provenance ``scenario.toml`` and ``run.json``: :mod:`redservo.runs.provenance`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from redservo.records.runlog import SimulationLog
from redservo.records.summary import Outcome, RunSummary

__all__ = ["SimulationResult"]


@dataclass
class SimulationResult:
    """The outcome, typed summary and log of one run."""

    outcome: Outcome
    summary: RunSummary
    log: SimulationLog
    provenance: Any = field(default=None, repr=False, compare=False)
    """What the run was made from (:class:`redservo.runs.provenance.Provenance`), set by
    :meth:`redservo.experiment.build.Experiment.run`; None for a bare :func:`simulate`."""
    engine: str = "compiled"
    """The controller's engine (:attr:`redservo.control.Controller.engine`)."""
    engine_reason: str = ""
    """Why the controller did not run compiled (one line), or ``""``."""

    def save(self, directory: str | Path, *, extra: dict[str, Any] | None = None) -> Path:
        """Write ``summary.json``, ``log.npz``, ``log.csv`` and ``diagnostics.json`` into
        ``directory``, and with a provenance the resolved ``scenario.toml`` and ``run.json``
        (:mod:`redservo.runs.provenance`: ``redservo run DIR/scenario.toml`` re-runs it)."""
        import json

        from redservo.runs.provenance import write_run_files

        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        summary = {**self.summary.to_dict(), **(extra or {})}
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        self.log.save_npz(out / "log.npz")
        self.log.save_csv(out / "log.csv")
        write_run_files(out, self)
        return out
