"""``redservo replay CAMPAIGN_DIR --sample K --method M``: re-run one campaign sample.

A campaign stores one row per (sample, method) in ``samples.csv``, not the runs' logs.
The sample is re-drawn from what ``definition.json`` holds (the definition, the base
scenario after its overrides, the seed): a sample depends only on (definition, seed,
index), see :mod:`redservo.campaign`. The method runs with the campaign's law options and
the run is saved as a self-describing run directory (``scenario.toml``: the sample's own
start and target, so ``redservo run DIR/scenario.toml`` re-runs it); the result is checked
against the stored row (outcome, iterations). A sample index the campaign did not run is
refused unless ``new=True`` (``--new``): then it is a new sample of the same definition and seed.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from redservo.errors import ConfigurationError

__all__ = ["Replay", "replay_sample"]


@dataclass(frozen=True)
class Replay:
    """A replayed sample: where it was saved, its result, and the stored row (or None)."""

    out: Path
    result: Any
    experiment: Any
    row: dict[str, Any] | None

    @property
    def matches(self) -> bool | None:
        """The replay ended like the stored row (outcome and iterations); None: no row."""
        if self.row is None:
            return None
        s = self.result.summary
        return bool(s.outcome == self.row["outcome"] and s.iterations == self.row["iterations"])


def _definition(campaign_dir: Path) -> tuple[Any, int]:
    """The campaign definition and seed stored in ``definition.json``."""
    from redservo.campaign import parse_campaign
    from redservo.campaign.definition import fingerprint_of
    from redservo.runs.files import relocate
    from redservo.runs.tomlwriter import dumps

    meta_path = campaign_dir / "definition.json"
    if not meta_path.is_file():
        raise ConfigurationError(
            f"{campaign_dir}: not a campaign directory (no definition.json); give the --out "
            "directory of redservo campaign",
            argument="path",
        )
    meta = json.loads(meta_path.read_text(encoding="utf-8"))
    try:
        own = fingerprint_of(meta["definition"], meta["scenario"], meta["seed"])
    except (KeyError, TypeError, ValueError, AttributeError):
        own = None
    if own is None or own != meta.get("fingerprint"):
        raise ConfigurationError(
            f"{meta_path} was edited (its definition, scenario or seed no longer give its "
            "fingerprint): the rows were not computed with what it says; rerun the campaign "
            "with --repair to rewrite it from the campaign's definition",
            argument="path",
        )
    table = {k: v for k, v in meta["definition"].items() if k != "overrides"}
    scenario = meta["scenario"]
    relocate(scenario, campaign_dir)  # a moved campaign: its copies of the files
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base-scenario.toml"
        base.write_text(dumps(scenario), encoding="utf-8")
        table["scenario"] = str(base)
        defn = parse_campaign(table, str(meta.get("source", campaign_dir)))
        defn.nominal  # noqa: B018 - evaluated while the base file exists
    return defn, int(meta["seed"])


def _row(campaign_dir: Path, sample: int, method: str) -> dict[str, Any] | None:
    from redservo.runs.replot import _campaign_rows

    if not (campaign_dir / "samples.csv").is_file():
        return None
    for row in _campaign_rows(campaign_dir):
        if row["sample"] == sample and row["method"] == method:
            return row
    return None


def _samples(campaign_dir: Path) -> int | None:
    """How many samples the campaign ran (``campaign.json``), or None when it never finished."""
    path = campaign_dir / "campaign.json"
    if not path.is_file():
        return None
    try:
        return int(json.loads(path.read_text(encoding="utf-8"))["samples"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _stored_samples(campaign_dir: Path) -> set[int]:
    from redservo.runs.replot import _campaign_rows

    if not (campaign_dir / "samples.csv").is_file():
        return set()
    return {int(row["sample"]) for row in _campaign_rows(campaign_dir)}


def _check_sample(root: Path, sample: int, new: bool) -> None:
    """Refuse a sample the campaign did not run, unless ``new`` (module docstring)."""
    if sample < 0:
        raise ConfigurationError(f"--sample must be >= 0, got {sample}", argument="sample")
    if new:
        return
    count = _samples(root)
    if count is not None and sample < count:
        return
    stored = _stored_samples(root)
    if sample in stored:
        return
    have = f"samples 0 to {count - 1}" if count else f"{len(stored)} stored sample(s)"
    raise ConfigurationError(
        f"{root}: sample {sample} is not in the campaign ({have}); add --new to run it as a "
        "new sample drawn from the same definition and seed",
        argument="sample",
    )


def replay_sample(
    campaign_dir: str | Path,
    sample: int,
    method: str,
    out: str | Path | None = None,
    *,
    new: bool = False,
) -> Replay:
    """Re-run sample ``sample`` (0-based) of a campaign with ``method`` and save it.

    Args:
        campaign_dir: The campaign's output directory.
        sample: Sample index, one the campaign ran.
        method: A method name (any method, not only the campaign's).
        out: Run directory (default ``CAMPAIGN_DIR/replay/sample-K-METHOD``).
        new: Allow an index the campaign did not run: a new sample drawn from the same
            definition and seed (a sample depends only on them and its index).

    Raises:
        ConfigurationError: not a campaign directory; ``sample`` negative, or not one the
            campaign ran (without ``new``).
        UnknownNameError: unknown method.
    """
    from redservo.experiment.build import build
    from redservo.redundancy import law_class

    root = Path(campaign_dir)
    law_class(method)
    defn, seed = _definition(root)
    _check_sample(root, sample, new)
    from redservo.campaign import draw_sample

    s = draw_sample(defn, seed, sample)
    exp = build(s.scenario)
    opts = defn.method_options.get(method)
    result = exp.run(method=method, law_options=dict(opts) if opts is not None else None)
    dest = Path(out) if out is not None else root / "replay" / f"sample-{sample}-{method}"
    result.save(dest, extra={"campaign": str(root), "sample": sample, "method": method})
    return Replay(dest, result, exp, _row(root, sample, method))
