"""CM01 §V-B (humanoid) reproduction, and the ``name[i]`` override syntax it relies on."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from redservo.errors import ScenarioError
from redservo.records.summary import SUCCESS_MARGIN
from redservo.reproduction import experiments
from redservo.reproduction.base import Runs, run_experiment
from redservo.reproduction.checks import IMPL, PAPER
from redservo.reproduction.cm01_humanoid import (
    decay_rate,
    fig16_humanoid_model,
    group_activation,
    group_speed_shares,
)
from redservo.reproduction.cm01_humanoid_sphere import EQ27, EQ27_CURRENT, PrintedEq27Task
from redservo.reproduction.cm01_humanoid_sphere import EXPERIMENTS as SPHERE
from redservo.reproduction.cm01_humanoid_tracking import EXPERIMENTS as TRACKING
from redservo.scenario import apply_overrides, load_scenario

SPECS = {spec.id: spec for spec in (*SPHERE, *TRACKING)}


def test_override_selects_an_entry_of_an_array_of_tables() -> None:
    sc = load_scenario("cm01-humanoid-sphere")
    out = apply_overrides(sc, ['features[0].variant="paper"', "objects[0].radius=0.12"])
    assert out.data["features"][0]["variant"] == "paper"
    assert out.data["objects"][0]["radius"] == 0.12
    assert sc.data["features"][0]["variant"] == "exact"  # the original is untouched


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ('features[1].variant="paper"', r"'features\[1\]' does not exist; indices 0 to 0"),
        ("control[0].lam=0.1", r"'control\[0\]' does not exist; no 'control' tables"),
        ('features[0].variant="nope"', "unknown sphere variant"),
    ],
)
def test_override_index_errors(assignment: str, message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        apply_overrides(load_scenario("cm01-humanoid-sphere"), [assignment])


# --------------------------------------------------------------------------- helpers


def test_decay_rate_of_an_exponential() -> None:
    t = np.arange(0.0, 20.0, 0.04)
    x = -0.3 * np.exp(-0.7 * t) + 1e-12  # tiny floor below the fitted window
    assert decay_rate(t, x) == pytest.approx(0.7, rel=1e-6)
    assert np.isnan(decay_rate(t[:3], x[:3]))
    assert np.isnan(decay_rate(t, np.zeros_like(t)))


def test_group_activation_and_speed_shares() -> None:
    k = np.arange(10.0)[:, None]
    qn = np.hstack([0.1 * k, 0.02 * k, -0.05 * k])  # group a: joint 0, group b: joints 1-2
    groups = {"a": (0,), "b": (1, 2)}
    assert group_activation(qn, groups, 0.25) == {"a": 3, "b": 5}
    assert group_activation(qn, groups, 10.0) == {"a": None, "b": None}
    qdot = np.tile([1.0, -2.0, 0.5], (10, 1))
    shares = group_speed_shares(qdot, [2.0, 4.0, 0.5], groups, 0, 10)
    assert shares == pytest.approx({"a": 1.0, "b": 2.0})  # b: max(2*2/4, 2*0.5/0.5)
    assert all(np.isnan(v) for v in group_speed_shares(qdot, [1.0] * 3, groups, 5, 5).values())


# --------------------------------------------------------------------------- experiments


@pytest.fixture(scope="module")
def sphere() -> Runs:
    return run_experiment(SPECS["cm01-humanoid-sphere"], fast=True)


@pytest.fixture(scope="module")
def tracking() -> Runs:
    return run_experiment(SPECS["cm01-humanoid-tracking"], fast=True)


def test_registered() -> None:
    assert experiments()["cm01-humanoid-sphere"] is SPECS["cm01-humanoid-sphere"]
    assert experiments()["cm01-humanoid-tracking"] is SPECS["cm01-humanoid-tracking"]


def test_sphere_claims(sphere: Runs) -> None:
    claims = {c.name: c for c in SPECS["cm01-humanoid-sphere"].claims(sphere)}
    assert len(claims) == 5
    # "No joint limit reached" needs every joint the success margin (1 % of its range) from
    # its limits: a run that ends nearer fails it, whatever its outcome (issue 34).
    failed = {name: c.evidence for name, c in claims.items() if not c.reproduced}
    assert "positioned-no-limit" in failed  # the quick run ends nearer than 1 % to a limit
    for ev in failed.values():
        margins = [v for k, v in ev.items() if k.endswith("min margin")]
        assert min(margins) < SUCCESS_MARGIN, ev
    assert claims["eq27-printed-converges"].kind == PAPER
    assert claims["classical-reaches-a-limit"].kind == IMPL  # a property of our set-up
    # Eq. 27's area entry is about half the exact one: the area converges ~2(1 + R²) faster.
    ratio = claims["eq27-printed-area-faster"].evidence["rate ratio eq. 27 / exact"]
    assert 1.6 < ratio < 2.4


def test_sphere_eq27_runs_use_the_paper_matrix(sphere: Runs) -> None:
    printed = sphere.experiments[EQ27].task
    assert isinstance(printed, PrintedEq27Task)
    # As printed: one constant matrix, whatever the feature value and the depth.
    L = printed.interaction(np.array([0.3, -0.2, 0.01]), [np.array([0.1, 0.2, 3.0])])
    np.testing.assert_array_equal(L, printed.L)
    np.testing.assert_allclose(L[0, 0], L[1, 1])  # -1/z_d twice
    assert L[2, 2] > 0 and np.count_nonzero(L[2]) == 1  # the area row: π R² / z_d only
    variants = {
        label: getattr(exp.task.terms[0].feature, "variant", None)
        for label, exp in sphere.experiments.items()
    }
    assert variants[EQ27_CURRENT] == "paper"
    assert variants["iterative-smooth"] == "exact"
    assert not isinstance(sphere.experiments["iterative-smooth"].task, PrintedEq27Task)


def test_fig16_is_labelled_as_our_geometry(tmp_path: Path) -> None:
    path = fig16_humanoid_model(tmp_path / "fig16.png")
    assert path.is_file() and path.stat().st_size > 10_000


def test_tracking_claims(tracking: Runs) -> None:
    claims = SPECS["cm01-humanoid-tracking"].claims(tracking)
    assert len(claims) == 5
    for c in claims:  # only "no limit reached" may fail, and only through the margin
        if not c.reproduced:
            assert c.name == "tracks-to-the-end", (c.name, c.evidence)
            margins = [v for k, v in c.evidence.items() if k.endswith("min margin")]
            assert min(margins) < SUCCESS_MARGIN, c.evidence
    assert [c.kind for c in claims].count(PAPER) == 3  # the tracking error is not CM01's


def test_tracking_order_read_from_the_logs(tracking: Runs) -> None:
    # Independent of the claim code: the eyes are stopped at their band before the neck is.
    log = tracking["iterative"].log
    eyes = int(np.argmax(log.constrained[:, 7:9].max(axis=1)))
    neck = int(np.argmax(log.constrained[:, 4:7].max(axis=1)))
    assert 0 < eyes < neck
    assert np.max(np.abs(log.q_normalized[:, 7])) <= 0.8 + 1e-6
    assert tracking["classical"].summary["limit_hit"]["axis"] in (7, 8)


def test_order_claim_can_fail(tracking: Runs) -> None:
    bad = copy.deepcopy(tracking.results)
    for label in ("iterative", "iterative-smooth"):
        qn = bad[label].log.q_normalized
        qn[:, [6, 7]] = qn[:, [7, 6]]  # swap eye pan and neck yaw: the neck now moves first
    claims = SPECS["cm01-humanoid-tracking"].claims(Runs(bad, tracking.experiments))
    assert not claims[0].reproduced


def test_figures_written(sphere: Runs, tracking: Runs, tmp_path: Path) -> None:
    paths = SPECS["cm01-humanoid-sphere"].figures(sphere, tmp_path)
    paths += SPECS["cm01-humanoid-tracking"].figures(tracking, tmp_path)
    names = {p.name for p in paths}
    assert {
        "fig16_humanoid_model.png",
        "fig17_humanoid_sphere.png",
        "fig18_humanoid_tracking.png",
    } <= names
    assert all(p.is_file() and p.stat().st_size > 10_000 for p in paths)
