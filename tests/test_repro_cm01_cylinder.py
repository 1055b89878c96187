"""CM01 §V-A4 (cylinder) reproduction: the claims hold on the logs and the figures are drawn."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from redservo.camera import Camera
from redservo.reproduction import experiments
from redservo.reproduction.base import Runs, run_experiment
from redservo.reproduction.cm01_cylinder import EXPERIMENTS, limb_line_pixels, path_length

SPEC = EXPERIMENTS[0]


@pytest.fixture(scope="module")
def runs() -> Runs:
    return run_experiment(SPEC, fast=True)


def test_registered() -> None:
    assert experiments()["cm01-cylinder"] is SPEC


def test_every_claim_reproduced(runs: Runs) -> None:
    claims = SPEC.claims(runs)
    assert len(claims) == 7
    failed = [(c.claim, c.evidence) for c in claims if not c.reproduced]
    assert not failed, failed


def test_paper_phenomena_on_the_logs(runs: Runs) -> None:
    # Independent of the claim code: read the logs directly.
    assert runs["classical"].summary["limit_hit"]["axis"] == 0
    it = runs["iterative"].log
    assert it.constrained[0, 0] == 1 and np.all(it.qdot[:, 0] == pytest.approx(0.0, abs=1e-12))
    first3 = int(np.argmax(it.constrained[:, 2]))
    assert 50 <= first3 <= 200  # CM01: "after about iteration 100"
    assert np.max(it.q_normalized[:, 2]) <= 0.8 + 1e-6  # stopped at its threshold


def test_figures_written(runs: Runs, tmp_path: Path) -> None:
    paths = SPEC.figures(runs, tmp_path)
    names = {p.name for p in paths}
    assert {"fig14_cylinder_images.png", "fig15_cylinder_distances_velocities.png"} <= names
    assert all(p.is_file() and p.stat().st_size > 10_000 for p in paths)


def test_stopped_claim_can_fail(runs: Runs) -> None:
    # If the in-band axis moved deeper, the claim must say so.
    bad = copy.deepcopy(runs.results)
    log = bad["iterative"].log
    log.qdot[:, 0] = 0.01
    log.q_normalized[5:, 0] = log.q_normalized[0, 0] + 0.05
    claims = SPEC.claims(Runs(bad, runs.experiments))
    stopped = next(c for c in claims if "is stopped" in c.claim)
    assert not stopped.reproduced


def test_transfer_claim_can_fail(runs: Runs) -> None:
    bad = copy.deepcopy(runs.results)
    bad["classical-unlimited"].log.q[:, [1, 5]] *= 10.0  # the reference now travels farther
    claims = SPEC.claims(Runs(bad, runs.experiments))
    transfer = next(c for c in claims if "transferred" in c.claim)
    assert not transfer.reproduced


def test_limb_line_pixels_lie_on_the_line() -> None:
    cam = Camera()
    rho, theta = 0.1, 2.5
    uv = limb_line_pixels(rho, theta, cam)
    xy = cam.pixel_to_normalized(uv)
    assert xy @ np.array([np.cos(theta), np.sin(theta)]) == pytest.approx([rho, rho])


def test_path_length() -> None:
    q = np.array([[0.0, 1.0], [1.0, 1.0], [0.5, 3.0]])
    assert path_length(q) == pytest.approx([1.5, 2.0])
    assert path_length(q[:1]) == pytest.approx([0.0, 0.0])
