"""MC05 reproduction (joint limits, the optical-axis variant, occlusion) and the
``features[i].components`` scenario option."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from redservo.errors import ScenarioError
from redservo.experiment.build import build
from redservo.reproduction import experiments
from redservo.reproduction.base import Runs, run_experiment
from redservo.reproduction.checks import IMPL, PAPER
from redservo.reproduction.mc05 import avoidance_split, occluder_disc
from redservo.reproduction.mc05_joint_limits import EXPERIMENTS as JOINT_LIMITS
from redservo.reproduction.mc05_occlusion import EXPERIMENTS as OCCLUSION
from redservo.reproduction.mc05_occlusion import figure7_features
from redservo.reproduction.mc05_optical_axis import EXPERIMENTS as OPTICAL_AXIS
from redservo.scenario import parse_scenario

_POINTS = [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]


def _moments_scenario(**feature: Any) -> dict[str, Any]:
    return {
        "robot": {"model": "afma6", "q0": [0.025, -0.04, -0.02, 0.0, 1.19, 0.0]},
        "objects": [
            {
                "name": "target",
                "kind": "points",
                "points": _POINTS,
                "pose_in_camera": {"translation": [0.05, -0.02, 0.8], "rotvec": [0.1, -0.1, 0.3]},
            }
        ],
        "features": [{"kind": "moments", "object": "target", **feature}],
        "task": {"desired_pose": {"translation": [0.0, 0.0, 0.6]}},
        "control": {"method": "classical"},
    }


def _state(data: dict[str, Any]) -> Any:
    exp = build(parse_scenario(data))
    J = exp.robot.jacobian(exp.q0)
    return exp, exp.task.evaluate(exp.scene, exp.robot.fkine(exp.q0), J, 0.0), J


def test_components_select_rows_of_the_error_and_jacobian() -> None:
    exp_all, full, J = _state(_moments_scenario())
    exp, sub, _ = _state(_moments_scenario(components=[3, 0, 1, 2]))
    assert exp_all.task.m == 6 and exp.task.m == 4
    np.testing.assert_allclose(sub.s, full.s)  # s is still measured in full
    np.testing.assert_allclose(sub.e1, full.e[:4], atol=1e-12)
    np.testing.assert_allclose(sub.J1, (full.L @ J)[:4], atol=1e-12)


def test_components_apply_to_each_point_of_a_point_entry() -> None:
    data = {
        "robot": {"model": "afma6", "q0": [0.025, -0.04, -0.02, 0.0, 1.19, 0.0]},
        "objects": [
            {
                "name": "p",
                "kind": "points",
                "points": [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]],
                "pose_in_camera": {"translation": [0.0, 0.0, 1.0]},
            }
        ],
        "features": [{"kind": "point", "object": "p", "components": [1]}],
        "task": {"desired": [0.0, 0.0, 0.0, 0.0]},
        "control": {"method": "classical"},
    }
    _, st, _ = _state(data)
    np.testing.assert_allclose(st.e1, st.e[[1, 3]])


@pytest.mark.parametrize("bad", [[], [6], [-1], [0, 0], [0.5], [True]])
def test_bad_components_name_the_key(bad: list[Any]) -> None:
    with pytest.raises(ScenarioError, match=r"features\[0\]\.components"):
        parse_scenario(copy.deepcopy(_moments_scenario(components=bad)))


# --------------------------------------------------------------------------- reproduction

SPECS = {spec.id: spec for spec in (*JOINT_LIMITS, *OPTICAL_AXIS, *OCCLUSION)}


@pytest.fixture(scope="module")
def occlusion_runs() -> Runs:
    return run_experiment(SPECS["mc05-occlusion"], fast=True)


def test_registered() -> None:
    known = experiments()
    assert known["mc05-joint-limits"] is SPECS["mc05-joint-limits"]
    assert known["mc05-occlusion"] is SPECS["mc05-occlusion"]
    assert known["mc05-optical-axis"] is SPECS["mc05-optical-axis"]


def test_occlusion_claims_reproduced(occlusion_runs: Runs) -> None:
    claims = {c.name: c for c in SPECS["mc05-occlusion"].claims(occlusion_runs)}
    assert len(claims) == 8
    failed = [name for name, c in claims.items() if not c.reproduced]
    # MC05 Fig. 7 says features are accelerated; individually some are pushed away.
    assert not failed, failed  # MC05 does not say that no feature is pushed away
    assert claims["avoidance-acts-on-task-only-to-help"].kind == IMPL
    assert claims["error-norm-never-slowed"].kind == IMPL


def test_figure7_per_feature(occlusion_runs: Runs) -> None:
    f7 = figure7_features(occlusion_runs)
    assert "xn" in f7["pushed away"] and f7["growth"]["xn"] > 2.0
    assert {"yn", "an"} <= set(f7["accelerated"])
    k0, k1 = f7["window"]
    assert 0 <= k0 < k1 < len(occlusion_runs["directional"].log)


def test_occlusion_outcomes_on_the_logs(occlusion_runs: Runs) -> None:
    # Read the logs directly, independently of the claim code.
    assert occlusion_runs["no avoidance"].outcome == "occluded"
    assert occlusion_runs["classical projector"].outcome == "occluded"
    d = occlusion_runs["directional"]
    exp = occlusion_runs.experiments["directional"]
    assert d.outcome == "converged" and len(d.log) == exp.options.max_iterations
    assert exp.task.m == 4 and d.log.e1.shape[1] == 4 and d.log.s.shape[1] == 6
    # The classical projector's run is longer than the no-avoidance one (it does avoid a bit).
    assert len(occlusion_runs["classical projector"].log) >= len(occlusion_runs["no avoidance"].log)


def test_avoidance_split_is_zero_without_a_secondary_command(occlusion_runs: Runs) -> None:
    # Without avoidance the command is exactly -λ J1⁺ e1: the split must leave nothing.
    split = avoidance_split(
        occlusion_runs["no avoidance"], occlusion_runs.experiments["no avoidance"]
    )
    assert np.max(np.abs(split.qdot2)) < 1e-9
    assert np.max(np.abs(split.twist2)) < 1e-9


def test_occluder_disc_matches_a_direct_projection(occlusion_runs: Runs) -> None:
    exp = occlusion_runs.experiments["directional"]
    log = occlusion_runs["directional"].log
    disc = occluder_disc(exp, log.q[0], 0.0)
    assert disc is not None
    # At t = 0 the sphere is where the scenario puts it in the start camera frame.
    X0 = np.array([0.306, 0.014, 0.57])
    np.testing.assert_allclose(disc[0], X0[:2] / X0[2], atol=1e-9)
    assert disc[1] == pytest.approx(0.044 / np.sqrt(0.57**2 - 0.044**2))


def test_occlusion_claims_can_fail(occlusion_runs: Runs) -> None:
    bad = copy.deepcopy(occlusion_runs.results)
    bad["directional"].outcome = "occluded"
    bad["no avoidance"].outcome = "converged"
    claims = {
        c.name: c for c in SPECS["mc05-occlusion"].claims(Runs(bad, occlusion_runs.experiments))
    }
    assert not claims["no-avoidance-occluded"].reproduced
    assert not claims["directional-avoids"].reproduced


def test_occlusion_figures_written(occlusion_runs: Runs, tmp_path: Path) -> None:
    paths = SPECS["mc05-occlusion"].figures(occlusion_runs, tmp_path)
    names = {p.name for p in paths}
    assert names == {
        "fig5_avoidance_velocities.png",
        "fig6_image_phases.png",
        "fig7_features.png",
    }
    assert all(p.is_file() and p.stat().st_size > 10_000 for p in paths)


@pytest.fixture(scope="module")
def joint_limit_runs() -> Runs:
    return run_experiment(SPECS["mc05-joint-limits"], fast=True)


def test_joint_limit_claims_reproduced(joint_limit_runs: Runs) -> None:
    claims = {c.name: c for c in SPECS["mc05-joint-limits"].claims(joint_limit_runs)}
    assert len(claims) == 8
    # "mainly an" is reported, reproduced or not (the limited x axis moves the camera
    # mostly along y here); the others must hold.
    failed = [name for name, c in claims.items() if not c.reproduced and name != "mainly-an"]
    assert not failed, failed
    assert claims["mainly-an"].evidence
    # Consequences of eq. 9 and set-up outcomes are implementation checks.
    for name in (
        "rank-null-far",
        "rank-not-null-near-limits",
        "not-slowed",
        "classical-ends-in-limit",
    ):
        assert claims[name].kind == IMPL, name
    assert [c.kind for c in claims.values()].count(PAPER) == 3


def test_optical_axis_variant_accelerates_an() -> None:
    spec = SPECS["mc05-optical-axis"]
    runs = run_experiment(spec, fast=True)
    claims = {c.name: c for c in spec.claims(runs)}
    failed = [name for name, c in claims.items() if not c.reproduced]
    assert not failed, [(n, claims[n].evidence) for n in failed]
    exp = runs.experiments["directional"]
    # The limited axis is z (axis 3), and it moves the camera along its optical axis.
    assert runs["classical"].summary["limit_hit"]["axis"] == 2
    u = exp.robot.jacobian(exp.q0)[:3, 2]
    assert abs(u[2]) / np.linalg.norm(u) > 0.95


def test_joint_limit_phenomena_on_the_logs(joint_limit_runs: Runs) -> None:
    # Read the logs directly, independently of the claim code.
    exp = joint_limit_runs.experiments["directional"]
    assert exp.task.m == 6 == exp.robot.n  # full-rank task: no classical redundancy
    cl = joint_limit_runs["classical"]
    assert cl.outcome == "joint_limit" and cl.summary["limit_hit"]["axis"] == 0
    # Without limits the classical path crosses the real x limit, so the limit is in the way.
    ref = joint_limit_runs["classical-unlimited"]
    assert ref.outcome == "converged"
    assert np.max(exp.limits.normalized(ref.log.q)[:, 0]) > 1.0
    d = joint_limit_runs["directional"]
    assert d.outcome == "converged"
    assert all(exp.limits.contains(q) for q in d.log.q)
    assert np.max(np.abs(d.log.q_normalized)) < 1.0
    # The directional run reaches the desired pose (target 0.6 m ahead, parallel, centred).
    cMo = exp.scene.cMo("target", exp.robot.fkine(d.log.q[-1]), 0.0)
    np.testing.assert_allclose(cMo[:3, 3], [0.0, 0.0, 0.6], atol=5e-3)
    np.testing.assert_allclose(cMo[:3, :3], np.eye(3), atol=1e-2)
    # The projector frees directions only while the force acts: the start is outside the bands.
    assert d.log.projector_rank[0] == 0 and d.log.projector_rank.max() > 0


def test_joint_limit_claims_can_fail(joint_limit_runs: Runs) -> None:
    bad = copy.deepcopy(joint_limit_runs.results)
    bad["classical"].outcome = "converged"
    bad["directional"].log.projector_rank[:] = 0.0
    spec = SPECS["mc05-joint-limits"]
    claims = {c.name: c for c in spec.claims(Runs(bad, joint_limit_runs.experiments))}
    assert not claims["classical-ends-in-limit"].reproduced
    assert not claims["rank-not-null-near-limits"].reproduced


def test_joint_limit_figures_written(joint_limit_runs: Runs, tmp_path: Path) -> None:
    paths = SPECS["mc05-joint-limits"].figures(joint_limit_runs, tmp_path)
    assert {p.name for p in paths} == {
        "fig2_joint_trajectories.png",
        "fig3_projector_rank.png",
        "fig4_features.png",
    }
    assert all(p.is_file() and p.stat().st_size > 10_000 for p in paths)
