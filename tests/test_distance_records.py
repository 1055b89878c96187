"""What the records say about distances: the summary's minimum per pair kind and steps
within d_influence, samples.csv's min_distance column, a campaign's collisions column
counting any overlap (min distance < 0) as a failure."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from redservo.campaign.table import RunTable
from redservo.cli.entry import main
from redservo.collision.tally import DistanceTally
from redservo.experiment.build import build
from redservo.scenario import load_scenario


def test_tally_keeps_the_minimum_per_kind_and_counts_steps_within_influence() -> None:
    tally = DistanceTally(0.1)
    kinds = ("environment", "environment", "self")
    tally.add(SimpleNamespace(d=np.array([0.3, 0.2, 0.15]), kinds=kinds))
    tally.add(SimpleNamespace(d=np.array([0.05, 0.2, 0.4]), kinds=kinds))
    tally.add(SimpleNamespace(d=np.zeros(0), kinds=()))
    assert tally.fields() == {
        "min_distance_by_kind": {"environment": 0.05, "self": 0.15},
        "steps_within_influence": 1,
    }


def test_summary_reports_the_minimum_per_pair_kind(tmp_path: Path) -> None:
    exp = build(load_scenario("panda-post"))
    coll = exp.options.collision
    assert coll is not None
    res = exp.run(method="gpm", collision=dataclasses.replace(coll, self_collision=True))
    s = res.summary
    by_kind = s.min_distance_by_kind
    assert by_kind is not None and set(by_kind) == {"environment", "self"}
    assert min(by_kind.values()) == s.min_distance
    assert by_kind["environment"] >= coll.d_safe - 1e-4
    assert s.steps_within_influence is not None
    assert 0 < s.steps_within_influence <= s.iterations
    res.save(tmp_path / "run")
    saved = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert saved["min_distance_by_kind"] == by_kind
    assert saved["steps_within_influence"] == s.steps_within_influence


def _row(**kw: Any) -> dict[str, Any]:
    row = {"sample": 0, "method": "gpm", "success": False, "attempts": 1}
    row.update({"outcome": "max_iterations", "min_distance": 0.03, **kw})
    return row


def test_collisions_column_counts_an_overlap_as_a_collision() -> None:
    table = RunTable(["gpm"], 2)
    table.add(_row(min_distance=-0.001))
    table.add(_row(sample=1))
    assert table.stats("gpm").collisions == 1


def test_samples_csv_has_each_runs_min_distance(tmp_path: Path) -> None:
    argv = ["campaign", "panda-posts", "--samples", "1", "--methods", "gpm", "--workers", "1"]
    assert main([*argv, "--no-plot", "-q", "--out", str(tmp_path / "c")]) == 0
    with (tmp_path / "c" / "samples.csv").open() as f:
        (row,) = list(csv.DictReader(f))
    assert float(row["min_distance"]) >= 0.02 - 1e-4
