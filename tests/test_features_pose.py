"""Pose-based features (PBVS): values, interaction matrices against finite differences, the
depth options, the scenario schema, every law, and the shipped PBVS scenarios."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.errors import ConfigurationError, ScenarioError
from redservo.features import PoseThetaU, PoseTranslation, make_feature, thetau_interaction
from redservo.spatial import exp_twist, inverse, make_transform, matrix_to_rotvec
from redservo.task import TaskTerm, VisualTask

VARIANTS = [
    ("pose_translation", "cdMc"),
    ("pose_translation", "cMo"),
    ("pose_translation", "cMcd"),
    ("pose_thetau", "cdRc"),
    ("pose_thetau", "cRcd"),
]


def _random_pose(rng: np.random.Generator, big: bool = False) -> np.ndarray:
    angle = 2.5 if big else 0.8
    return make_transform(
        t=rng.uniform(-0.2, 0.2, 3) + np.array([0.0, 0.0, 0.6]),
        rotvec=rng.uniform(-angle, angle, 3),
    )


def _fd(feature, cMo: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """d s / d v_c by central differences: the camera moves by exp(v_c dt), the object not."""
    out = np.zeros((3, 6))
    for j in range(6):
        v = np.zeros(6)
        v[j] = 1.0
        sp = feature.measure(inverse(exp_twist(v, h)) @ cMo).s
        sm = feature.measure(inverse(exp_twist(v, -h)) @ cMo).s
        out[:, j] = (sp - sm) / (2.0 * h)
    return out


@pytest.mark.parametrize(("kind", "variant"), VARIANTS)
def test_interaction_matches_finite_differences(kind: str, variant: str) -> None:
    rng = np.random.default_rng(len(kind) + len(variant))
    for k in range(6):
        cdMo = _random_pose(rng)
        cMo = _random_pose(rng, big=k >= 3)  # rotations up to ~2.5 rad away too
        f = make_feature(kind, variant=variant, desired=cdMo)
        m = f.measure(cMo)
        np.testing.assert_allclose(f.interaction(m.s, m.inv_depth), _fd(f, cMo), atol=2e-6)


def test_values_and_desired_values() -> None:
    rng = np.random.default_rng(7)
    cdMo, cMo = _random_pose(rng), _random_pose(rng)
    cdMc = cdMo @ inverse(cMo)
    np.testing.assert_allclose(PoseTranslation("cdMc", cdMo).value(cMo), cdMc[:3, 3])
    np.testing.assert_allclose(PoseTranslation("cMo").value(cMo), cMo[:3, 3])
    np.testing.assert_allclose(PoseTranslation("cMcd", cdMo).value(cMo), inverse(cdMc)[:3, 3])
    tu = matrix_to_rotvec(cdMc[:3, :3])
    np.testing.assert_allclose(PoseThetaU("cdRc", cdMo).value(cMo), tu, atol=1e-12)
    np.testing.assert_allclose(PoseThetaU("cRcd", cdMo).value(cMo), -tu, atol=1e-12)
    for kind, variant in VARIANTS:  # at the desired pose: s* = 0 (c t_o* for cMo)
        f = make_feature(kind, variant=variant, desired=cdMo)
        want = cdMo[:3, 3] if variant == "cMo" else np.zeros(3)
        np.testing.assert_allclose(f.value(cdMo), want, atol=1e-12)
    np.testing.assert_allclose(thetau_interaction(np.zeros(3)), np.eye(3))


def test_depth_options_act_on_the_rotation_of_cdMc() -> None:
    """The parameters (θu, 1) of c*R_c: a depth factor cancels, the desired ones give I."""
    rng = np.random.default_rng(3)
    cdMo, cMo = _random_pose(rng), _random_pose(rng)
    f = PoseTranslation("cdMc", cdMo)
    task = VisualTask.from_desired_poses([TaskTerm(f, "o")], {"o": cdMo})
    m = f.measure(cMo)
    L = f.interaction(m.s, m.inv_depth)
    np.testing.assert_allclose(task.interaction(m.s, [m.inv_depth], depth_scale=1.7), L)
    np.testing.assert_allclose(f.interaction(m.s, task.inv_depth_star[0])[:, :3], np.eye(3))
    assert PoseThetaU("cdRc", cdMo).measure(cMo).inv_depth.shape == (0,)


def test_bad_options() -> None:
    with pytest.raises(ConfigurationError, match="translation variant"):
        PoseTranslation("cdRc")  # type: ignore[arg-type]
    with pytest.raises(ConfigurationError, match="needs desired"):
        PoseTranslation("cdMc")
    with pytest.raises(ConfigurationError, match="rotation variant"):
        PoseThetaU("cMo")  # type: ignore[arg-type]
    with pytest.raises(ConfigurationError, match="needs desired"):
        make_feature("pose_thetau", variant="cRcd")


def _load(name: str, *sets: str):
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    return build(apply_overrides(load_scenario(name), list(sets)))


def test_schema_needs_the_desired_pose(tmp_path) -> None:
    from importlib.resources import files

    from redservo.scenario import load_scenario

    text = (files("redservo") / "scenarios" / "afma6-pbvs.toml").read_text(encoding="utf-8")
    path = tmp_path / "no-desired.toml"
    path.write_text(text.replace("desired_pose =", "# desired_pose ="), encoding="utf-8")
    with pytest.raises(ScenarioError, match="desired_pose"):
        _ = load_scenario(path).spec


def test_every_law_decreases_the_pbvs_error() -> None:
    from redservo.redundancy import METHODS

    for method in METHODS:
        res = _load("afma6-pbvs", f'control.method="{method}"', "simulation.max_iterations=6").run()
        assert res.outcome in ("converged", "max_iterations"), (method, res.outcome)
        e = res.log.error_norm
        assert e[-1] < 0.95 * e[0], method


def test_pbvs_with_the_ideal_sensor_converges() -> None:
    res = _load("afma6-pbvs").run()
    assert res.outcome == "converged" and res.summary.success


def test_the_campaign_loop_refuses_pose_features_with_a_reason() -> None:
    """A campaign on pose features leaves the compiled loop with this one-line reason."""
    from redservo.bench.sensed import sensed_iteration
    from redservo.campaign.fastloop import experiment_reason

    e = _load("afma6-pbvs")
    why = "only image points and moments are compiled"
    assert why in str(experiment_reason(e))
    with pytest.raises(ConfigurationError, match=why):
        sensed_iteration(e.robot, e.scene, e.task, e.law, limits=e.limits, lam=0.8, dt=0.04)


def test_log_depth_interaction_and_parameters() -> None:
    """The 2½-D task's log Z: L against finite differences; a depth factor scales 1/Z only."""
    from redservo.features import LogDepth

    rng = np.random.default_rng(5)
    f = LogDepth([0.03, -0.02, 0.01])
    out = np.zeros((1, 6))
    for _ in range(4):
        cMo = _random_pose(rng)
        m = f.measure(cMo)
        X = cMo[:3, :3] @ f.point_o + cMo[:3, 3]
        assert m.s[0] == pytest.approx(np.log(X[2]))
        h = 1e-6
        for j in range(6):
            v = np.zeros(6)
            v[j] = 1.0
            sp = f.measure(inverse(exp_twist(v, h)) @ cMo).s
            sm = f.measure(inverse(exp_twist(v, -h)) @ cMo).s
            out[:, j] = (sp - sm) / (2.0 * h)
        L = f.interaction(m.s, m.inv_depth)
        np.testing.assert_allclose(L, out, atol=1e-6)
        L2 = f.interaction(m.s, m.inv_depth / 2.0)  # depth overestimated twice
        np.testing.assert_allclose(L2[0, 2], L[0, 2] / 2.0)
        np.testing.assert_allclose(L2[0, 3:], L[0, 3:])
