"""Tests of the Monte Carlo campaign runner (redservo.campaign)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.stats import binomtest

import redservo
from redservo import campaign as cmp
from redservo.campaign import (
    draw_sample,
    load_campaign,
    method_stats,
    parse_campaign,
    run_campaign,
    sample_start,
    shipped_campaigns,
    wilson_interval,
)
from redservo.errors import ConfigurationError, ScenarioError, UnknownNameError
from redservo.limits import JointLimits
from redservo.scenario import shipped_scenarios

# A quick campaign: two methods, a short iteration cap (many runs stop at the cap: fine here).
BASE: dict[str, Any] = {
    "name": "quick",
    "scenario": "afma6-gaze-demo",
    "samples": 3,
    "methods": ["classical", "iterative-smooth"],
    "overrides": {"control": {"lam": 2.0}, "simulation": {"max_iterations": 30}},
    "start": {"p_band": 0.5, "band_beyond": 0.5, "min_margin": 0.01, "min_in_band": 1},
    "target": {"translation": [0.1, 0.1, [-0.1, 0.2]], "image_margin_px": 10},
}


def quick(**changes: Any) -> cmp.CampaignDefinition:
    data = {**BASE, **changes}
    return parse_campaign(data, "quick.toml")


# --------------------------------------------------------------------------- statistics


def test_wilson_interval_known_counts() -> None:
    z = 1.959963984540054
    # k = 0: the interval is [0, z²/(n + z²)]; k = n: [n/(n + z²), 1] (closed forms).
    assert wilson_interval(0, 10) == pytest.approx((0.0, z * z / (10 + z * z)))
    assert wilson_interval(0, 10)[1] == pytest.approx(0.27753, abs=1e-5)
    assert wilson_interval(20, 20) == pytest.approx((20 / (20 + z * z), 1.0))
    # 8/10 by hand: p = 0.8, denom = 1 + z²/10 = 1.384146, centre = (0.8 + 0.192073)/denom
    # = 0.716738, half = z sqrt(0.016 + 0.009604)/denom = 0.226578.
    assert wilson_interval(8, 10) == pytest.approx((0.490160, 0.943316), abs=1e-5)
    # Independent implementation.
    for k, n in [(3, 7), (50, 200), (199, 200), (1, 1)]:
        ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
        assert wilson_interval(k, n) == pytest.approx((ci.low, ci.high), abs=1e-9)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    with pytest.raises(ConfigurationError):
        wilson_interval(3, 2)


def _row(outcome: str, iterations: int, speed: float) -> dict[str, Any]:
    return {
        "outcome": outcome,
        "success": outcome == "converged",
        "iterations": iterations,
        "max_joint_speed": speed,
        "max_cam_translation": speed,
        "max_cam_rotation": speed,
        "discontinuity": 0.1,
        "min_margin": 0.2,
    }


def test_feature_lost_is_a_failure_shown_with_the_target_lost_not_an_error() -> None:
    rows = [_row("converged", 100, 1.0), _row("feature_lost", 40, 2.0), _row("error", 0, 0.0)]
    s = method_stats("m", rows)
    assert (s.feature_lost, s.target_lost, s.other_failures) == (1, 0, 1)
    line = cmp.stats_table([s]).splitlines()[-1]
    assert "(+1 errors)" in line and "| 0 (+1 feature lost) |" in line


def test_method_stats_counts_and_medians() -> None:
    rows = [
        _row("converged", 100, 1.0),
        _row("converged", 200, 2.0),
        _row("converged", 300, 3.0),
        _row("joint_limit", 5, 10.0),
        _row("joint_limit", 7, 4.0),
        _row("target_lost", 9, 5.0),
        _row("max_iterations", 400, 6.0),
        _row("error", 0, float("nan")),
    ]
    s = method_stats("m", rows)
    assert (s.runs, s.successes, s.limit_hits, s.target_lost) == (8, 3, 2, 1)
    assert (s.max_iterations, s.other_failures) == (1, 1)
    assert s.success_rate == 3 / 8
    assert (s.ci_low, s.ci_high) == wilson_interval(3, 8)
    assert s.iterations_median == 200.0  # successes only
    assert s.iterations_p90 == pytest.approx(280.0)  # 100, 200, 300: linear interpolation
    assert s.joint_speed_median == 4.0  # all 7 finite runs: 1, 2, 3, 4, 5, 6, 10
    none = method_stats("m", [_row("joint_limit", 3, 1.0)])
    assert math.isnan(none.iterations_median) and none.successes == 0


# --------------------------------------------------------------------------- sampler


@pytest.mark.parametrize("rho", [0.05, 0.1, 0.2])
def test_sample_start_band_and_limits(rho: float) -> None:
    rng = np.random.default_rng(1)
    lim = JointLimits([-1.0, 0.0, -3.0, 2.0, -0.1], [2.0, 0.5, 3.0, 2.2, 0.1], rho)
    beyond, min_margin, p = 0.5, 0.02, 0.3
    outer = (1 + beyond) * rho
    eligible = [0, 2, 3, 4]
    counts = np.zeros(5)
    in_threshold_band = 0
    draws = 2000
    for _ in range(draws):
        q, near = sample_start(
            lim,
            rng,
            p_band=p,
            band_beyond=beyond,
            min_margin=min_margin,
            min_in_band=1,
            eligible=eligible,
        )
        margin = lim.margin(q)
        assert lim.contains(q)
        assert np.all(margin >= min_margin - 1e-12)
        assert np.all(margin[near] <= outer + 1e-12)
        assert np.all(margin[~near] >= outer - 1e-12)
        assert near.sum() >= 1 and not near[1]  # joint 1 is not eligible
        counts += near
        in_threshold_band += int(np.sum(lim.in_band(q) & near))
    # Eligible joints are in the band with probability p, raised a little by min_in_band = 1:
    # P(near_i) = p + (1 - p)^4 / 4 for 4 eligible joints.
    expect = p + (1 - p) ** 4 / 4
    sd = math.sqrt(expect * (1 - expect) / draws)
    assert np.all(np.abs(counts[eligible] / draws - expect) < 5 * sd)
    # Margin uniform in [min_margin, outer]: the fraction beyond the threshold q̃ (margin < rho)
    # is (rho - min_margin) / (outer - min_margin).
    frac = in_threshold_band / counts.sum()
    assert frac == pytest.approx((rho - min_margin) / (outer - min_margin), abs=0.05)


def test_sample_start_rejects_bad_band() -> None:
    lim = JointLimits([0.0], [1.0], 0.2)
    rng = np.random.default_rng(0)
    with pytest.raises(ConfigurationError, match="band_beyond"):
        sample_start(lim, rng, p_band=0.5, band_beyond=2.0, min_margin=0.0)
    with pytest.raises(ConfigurationError, match="min_margin"):
        sample_start(lim, rng, p_band=0.5, band_beyond=0.5, min_margin=0.4)
    with pytest.raises(ConfigurationError, match="min_in_band"):
        sample_start(lim, rng, p_band=0.5, band_beyond=0.5, min_margin=0.0, min_in_band=2)


def test_draw_sample_is_deterministic_and_in_view() -> None:
    d = quick()
    a, b = draw_sample(d, 7, 2), draw_sample(d, 7, 2)
    assert np.array_equal(a.q0, b.q0) and np.array_equal(a.translation, b.translation)
    assert a.scenario.data == b.scenario.data
    assert not np.array_equal(a.q0, draw_sample(d, 8, 2).q0)
    assert not np.array_equal(a.q0, draw_sample(d, 7, 3).q0)
    # The drawn q0 is the sampler's output from the documented seed of that attempt.
    rng = np.random.default_rng(np.random.SeedSequence(7, spawn_key=(2, a.attempts)))
    q, near = sample_start(
        d.nominal.limits, rng, p_band=0.5, band_beyond=0.5, min_margin=0.01, min_in_band=1
    )
    assert np.array_equal(q, a.q0) and np.array_equal(near, a.near)
    # The target keeps its nominal pose in the start camera frame, translated by t.
    cMo = a.scenario.data["objects"][0]["pose_in_camera"]["translation"]
    assert np.allclose(cMo, d.nominal.cMo["target"][:3, 3] + a.translation)


def test_invalid_starts_are_redrawn_deterministically() -> None:
    # Half of the draws put the target off the image: some samples need several attempts.
    d = quick(target={"translation": [0.6, 0.0, 0.0], "image_margin_px": 10})
    samples = [draw_sample(d, 0, i) for i in range(6)]
    assert any(s.attempts > 0 for s in samples)
    for s in samples:
        assert cmp._start_problem(d, s.scenario) is None
        assert draw_sample(d, 0, s.number).attempts == s.attempts
    behind = quick(target={"translation": [0, 0, [-3.0, -2.0]]}, max_attempts=3)
    with pytest.raises(ScenarioError, match=r"key 'target'.*no valid start in 3 draws"):
        draw_sample(behind, 0, 0)


# --------------------------------------------------------------------------- definitions


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"start": {"p_band": 1.5}}, "start.p_band"),
        ({"start": {"band_beyond": 5.0}}, "start.band_beyond"),
        ({"start": {"min_margin": 0.3}}, "start.min_margin"),
        ({"start": {"joints": ["x", "knee"]}}, "start.joints[1]"),
        ({"start": {"min_in_band": 7}}, "start.min_in_band"),
        ({"start": {"wobble": 1}}, "start.wobble"),
        ({"methods": ["classical", "nope"]}, "methods[1]"),
        ({"methods": []}, "methods"),
        ({"samples": 0}, "samples"),
        ({"target": {"translation": [0.1, 0.1]}}, "target.translation"),
        ({"target": {"rotation_deg": [1, [3, 2], 1]}}, "target.rotation_deg[1]"),
        ({"target": {"motion_frame": "robot"}}, "target.motion_frame"),
        ({"errors": {"depth_scale": [0.0, 1.2]}}, "errors.depth_scale"),
        ({"errors": {"noise_std": "big"}}, "errors.noise_std"),
        ({"method_options": {"gpm": {"alpha": -1.0}}}, "method_options.gpm"),
        ({"method_options": {"gpm": {"nonsense": 1}}}, "method_options.gpm"),
        ({"overrides": {"simulation": {"max_iterations": "many"}}}, "overrides"),
        ({"scenario": "no-such-scenario"}, "scenario"),
        ({"colour": "red"}, "colour"),
    ],
)
def test_bad_definition_names_file_and_key(change: dict[str, Any], key: str) -> None:
    with pytest.raises(ScenarioError) as info:
        parse_campaign({**BASE, **change}, "my-campaign.toml")
    msg = str(info.value)
    assert msg.startswith("my-campaign.toml: ") and f"key '{key}" in msg, msg


def test_missing_scenario_key_and_bad_files(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="key 'scenario'"):
        parse_campaign({"samples": 3}, "x.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("samples = [")
    with pytest.raises(ScenarioError, match=r"bad\.toml: not valid TOML"):
        load_campaign(bad)
    with pytest.raises(ScenarioError, match="unknown campaign"):
        load_campaign("no-such-campaign")


def test_definition_file_with_relative_scenario_path(tmp_path: Path) -> None:
    scen = Path(__file__).parents[1] / "src/redservo/scenarios/afma6-gaze-demo.toml"
    (tmp_path / "base.toml").write_text(scen.read_text())
    (tmp_path / "c.toml").write_text('scenario = "base.toml"\nsamples = 2\n')
    d = load_campaign(tmp_path / "c.toml")
    assert d.scenario.source == str(tmp_path / "base.toml") and d.samples == 2


def test_shipped_campaigns_load_and_draw() -> None:
    names = shipped_campaigns()
    assert {"afma6-gaze-demo", "cm01-gaze", "mc05-joint-limits", "cm01-humanoid-tracking"} <= set(
        names
    )
    root = Path(redservo.__file__).parent / "scenarios" / "campaigns"
    missing = []
    for name in names:
        base = tomllib.loads((root / f"{name}.toml").read_text())["scenario"]
        if base not in shipped_scenarios():
            missing.append(base)
            continue
        d = load_campaign(name)
        s = draw_sample(d, 0, 0)
        assert d.nominal.limits.contains(s.q0) and s.near.sum() >= d.start.min_in_band
    if missing:
        pytest.skip(f"base scenarios not shipped yet: {', '.join(missing)}")


# --------------------------------------------------------------------------- runs


def _strip(rows: Any) -> list[dict[str, Any]]:
    """Rows with NaN replaced (NaN != NaN) so lists of rows compare by value."""
    return [
        {k: ("nan" if isinstance(v, float) and math.isnan(v) else v) for k, v in r.items()}
        for r in rows
    ]


def test_same_seed_same_rows_whatever_the_workers() -> None:
    d = quick()
    one = run_campaign(d, seed=3, workers=1, progress=False)
    again = run_campaign(d, seed=3, workers=1, progress=False)
    two = run_campaign(d, seed=3, workers=2, progress=False)
    assert len(one.rows) == 3 * 2
    assert _strip(one.rows) == _strip(again.rows) == _strip(two.rows)
    # Every method ran on the same samples.
    for i in range(3):
        a, b = (r for r in one.rows if r["sample"] == i)
        assert {k: v for k, v in a.items() if k.startswith(("q0_", "target_"))} == {
            k: v for k, v in b.items() if k.startswith(("q0_", "target_"))
        }
    other = run_campaign(d, seed=4, workers=1, progress=False)
    assert _strip(other.rows) != _strip(one.rows)


def test_resume_reuses_finished_rows(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from redservo.campaign import task as campaign_task

    calls: list[tuple[int, str]] = []
    real = campaign_task._run_task

    def counting(task: Any) -> dict[str, Any]:
        calls.append((task.sample, task.method))
        return real(task)

    monkeypatch.setattr(campaign_task, "_run_task", counting)
    d, out = quick(), tmp_path / "c"
    first = run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False)
    assert len(calls) == 4 and first.computed == 4
    calls.clear()
    full = run_campaign(d, samples=4, seed=1, workers=1, out=out, progress=False)
    assert sorted(calls) == [(i, m) for i in (2, 3) for m in ("classical", "iterative-smooth")]
    assert full.computed == 4
    assert _strip(full.rows[:4]) == _strip(first.rows)
    # Nothing left to do; a fresh in-memory run gives the same rows as the resumed one.
    calls.clear()
    assert run_campaign(d, samples=4, seed=1, workers=1, out=out, progress=False).computed == 0
    assert calls == []
    fresh = run_campaign(d, samples=4, seed=1, workers=1, progress=False)
    assert _strip(fresh.rows) == _strip(full.rows)
    # A line cut short by an interrupted write is dropped and its run redone.
    csv = out / "samples.csv"
    text = csv.read_text()
    csv.write_text(text[: len(text) - 40])
    calls.clear()
    again = run_campaign(d, samples=4, seed=1, workers=1, out=out, progress=False)
    assert calls == [(3, "iterative-smooth")]
    assert _strip(again.rows) == _strip(full.rows)
    # Another seed or definition in the same directory is refused.
    with pytest.raises(ConfigurationError, match="another definition or seed"):
        run_campaign(d, samples=4, seed=2, workers=1, out=out, progress=False)
    with pytest.raises(ConfigurationError, match="another definition or seed"):
        run_campaign(quick(start={"p_band": 0.9}), seed=1, workers=1, out=out, progress=False)


def test_outputs_and_pandas(tmp_path: Path) -> None:
    pd = pytest.importorskip("pandas")
    d = quick()
    res = run_campaign(d, samples=3, seed=0, workers=1, out=tmp_path, progress=False)
    df = pd.read_csv(tmp_path / "samples.csv")
    assert len(df) == 6 and set(df["method"]) == {"classical", "iterative-smooth"}
    assert df["success"].dtype == bool
    assert (df["success"] == (df["outcome"] == "converged")).all()
    for col in ("q0_x", "target_tz", "iterations", "min_margin", "max_cam_rotation"):
        assert col in df.columns
    assert np.allclose(df["q0_x"], [r["q0_x"] for r in res.rows])
    for name in ("campaign.json", "campaign.md", "definition.json"):
        assert (tmp_path / name).is_file()
    assert (tmp_path / "campaign.md").read_text() == res.markdown
    assert "| classical |" in res.markdown and "| iterative-smooth |" in res.markdown
    pytest.importorskip("matplotlib")
    assert {p.name for p in res.figures} == {"success_rate.png", "iterations.png"}


def test_method_options_and_errors_reach_the_run() -> None:
    d = quick(
        methods=["gpm"],
        method_options={"gpm": {"alpha": 2.0}},
        errors={
            "noise_std": [0.001, 0.002],
            "depth_scale": [0.8, 1.2],
            "hand_eye_translation": 0.01,
        },
    )
    s = draw_sample(d, 0, 0)
    sim = s.scenario.data["simulation"]
    assert 0.001 <= sim["noise_std"] <= 0.002 and 0.8 <= sim["depth_scale"] <= 1.2
    assert np.all(np.abs(sim["eMc_error"]["translation"]) <= 0.01)
    res = run_campaign(d, samples=1, workers=1, progress=False)
    assert res.rows[0]["noise_std"] == sim["noise_std"]


def test_run_campaign_rejects_bad_arguments() -> None:
    d = quick()
    with pytest.raises(UnknownNameError):
        run_campaign(d, methods=["nope"], progress=False)
    with pytest.raises(ConfigurationError, match="seed"):
        run_campaign(d, seed=-1, progress=False)
    with pytest.raises(ConfigurationError, match="samples"):
        run_campaign(d, samples=0, progress=False)


def test_cli_campaign(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from redservo.cli.entry import main

    path = tmp_path / "c.toml"
    path.write_text(
        'scenario = "afma6-gaze-demo"\nmethods = ["classical"]\n'
        "[overrides]\nsimulation = { max_iterations = 20 }\n"
    )
    out = tmp_path / "out"
    code = main(
        ["campaign", str(path), "--samples", "2", "--workers", "1", "--out", str(out), "-q"]
    )
    assert code == 0
    assert "| classical | " in capsys.readouterr().out
    assert (out / "samples.csv").is_file()
    assert main(["campaign", str(path), "--methods", "nope", "--out", str(out), "-q"]) == 2


HUMANOID_TRACKING = """
[robot]
model = "humanoid9"
q0 = [0, 0, 0, 0, 0, 0, 0, 0, 0]
[[objects]]
name = "target"
kind = "points"
points = [[0.0, 0.0, 0.0]]
pose_in_camera = { translation = [0.1, 0.05, 1.5] }
[objects.motion]
kind = "constant_velocity"
velocity = [0.0, 0.1, 0.05]
[[features]]
kind = "point"
object = "target"
[task]
desired = [0.0, 0.0]
[control]
method = "gpm"
[simulation]
max_iterations = 20
stop_at_convergence = false
tolerance = 0.01
"""


@pytest.mark.parametrize("frame", ["camera", "world"])
def test_object_motion_follows_the_start_camera(tmp_path: Path, frame: str) -> None:
    (tmp_path / "track.toml").write_text(HUMANOID_TRACKING)
    d = parse_campaign(
        {"scenario": "track.toml", "target": {"motion_frame": frame}, "start": {"p_band": 1.0}},
        "c.toml",
        base_dir=tmp_path,
    )
    s = draw_sample(d, 0, 0)
    v = np.asarray(s.scenario.data["objects"][0]["motion"]["velocity"])
    nominal_world = np.array([0.0, 0.1, 0.05])
    if frame == "world":
        assert np.array_equal(v, nominal_world)
    else:  # same velocity relative to the start camera as in the base scenario
        bRc = d.nominal.fkine(s.q0)[:3, :3]
        assert np.allclose(bRc.T @ v, d.nominal.bRc.T @ nominal_world)
        assert not np.allclose(v, nominal_world)
    res = run_campaign(d, samples=1, methods=["gpm"], workers=1, progress=False)
    assert "Tracking task" in res.markdown and res.rows[0]["iterations"] <= 20
    if frame == "camera":
        pytest.importorskip("matplotlib")
        out = run_campaign(
            d, samples=1, methods=["gpm"], workers=1, out=tmp_path / "o", progress=False
        )
        assert {p.name for p in out.figures} == {"success_rate.png", "final_error.png"}


# --------------------------------------------------------------------------- storage


def _csv_keys(path: Path) -> list[tuple[int, str]]:
    import csv

    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    return [(int(r["sample"]), r["method"]) for r in rows]


def test_resume_removes_duplicates_and_torn_rows(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d, out = quick(), tmp_path / "c"
    first = run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False)
    csv = out / "samples.csv"
    lines = csv.read_text().splitlines(keepends=True)
    # What two unlocked writers used to leave: every row twice, then a line cut short.
    csv.write_text("".join(lines) + "".join(lines[1:]) + lines[1][:30])
    capsys.readouterr()
    again = run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False)
    assert again.computed == 0 and _strip(again.rows) == _strip(first.rows)
    keys = _csv_keys(csv)
    assert len(keys) == len(set(keys)) == 4
    err = capsys.readouterr().err
    assert "removed 1 torn, 4 duplicate" in err and "kept 4 row(s)" in err


def _resealed(line: str, fingerprint: str) -> str:
    """A row line whose fields were changed, with the check its writer would have given it."""
    from redservo.campaign.rowfile import _check

    body = line.rstrip("\n").rpartition(",")[0]
    return f"{body},{_check(fingerprint, body)}\n"


def test_an_error_row_is_replaced_by_a_finished_one(tmp_path: Path) -> None:
    d, out = quick(), tmp_path / "c"
    run_campaign(d, samples=1, seed=0, workers=1, out=out, progress=False)
    csv = out / "samples.csv"
    header, *rows = csv.read_text().splitlines(keepends=True)
    broken = rows[0].replace(",converged,", ",error,").replace(",max_iterations,", ",error,")
    broken = _resealed(broken, d.fingerprint(0))  # as a worker that failed would have written it
    csv.write_text(header + broken + "".join(rows))  # an error row first, then the real one
    res = run_campaign(d, samples=1, seed=0, workers=1, out=out, progress=False)
    assert res.computed == 0 and all(r["outcome"] != "error" for r in res.rows)
    assert len(_csv_keys(csv)) == 2


def test_the_output_directory_is_locked(tmp_path: Path) -> None:
    import threading

    from redservo.campaign.lock import DirectoryLock

    d, out = quick(), tmp_path / "c"
    lock = DirectoryLock(out)
    with pytest.raises(ConfigurationError, match=r"in use by another redservo campaign.*--wait"):
        run_campaign(d, samples=1, workers=1, out=out, progress=False)
    timer = threading.Timer(0.5, lock.release)
    timer.start()
    res = run_campaign(d, samples=1, workers=1, out=out, progress=False, wait=True)
    timer.join()
    assert res.computed == 2
    with DirectoryLock(out):  # released at the end of the campaign
        pass


def test_a_damaged_definition_is_named_and_repaired(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    d, out = quick(), tmp_path / "c"
    first = run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False)
    meta = out / "definition.json"
    meta.write_text(meta.read_text()[:50])  # cut short
    with pytest.raises(ConfigurationError, match=r"definition.json is damaged.*--repair"):
        run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False)
    fixed = run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False, repair=True)
    assert fixed.computed == 0 and _strip(fixed.rows) == _strip(first.rows)
    # Missing definition.json next to rows of *another* seed: repair keeps none of them.
    meta.unlink()
    with pytest.raises(ConfigurationError, match=r"definition.json is missing.*--repair"):
        run_campaign(d, samples=2, seed=2, workers=1, out=out, progress=False)
    other = run_campaign(d, samples=2, seed=2, workers=1, out=out, progress=False, repair=True)
    assert other.computed == 4 and len(_csv_keys(out / "samples.csv")) == 4


def test_a_damaged_header_is_named_and_repaired(tmp_path: Path) -> None:
    d, out = quick(), tmp_path / "c"
    first = run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False)
    csv = out / "samples.csv"
    header, rest = csv.read_text().split("\n", 1)
    csv.write_text(header[:25] + "\n" + rest)
    with pytest.raises(ConfigurationError, match=r"header of .*samples.csv is damaged.*--repair"):
        run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False)
    fixed = run_campaign(d, samples=2, seed=1, workers=1, out=out, progress=False, repair=True)
    assert fixed.computed == 0 and _strip(fixed.rows) == _strip(first.rows)
    assert csv.read_text().split("\n", 1)[0] == header


def test_another_row_format_is_refused(tmp_path: Path) -> None:
    import json

    d, out = quick(), tmp_path / "c"
    run_campaign(d, samples=1, seed=1, workers=1, out=out, progress=False)
    meta = json.loads((out / "definition.json").read_text())
    meta.update(format=2, fingerprint="0" * 64)
    (out / "definition.json").write_text(json.dumps(meta))
    with pytest.raises(ConfigurationError, match="row format 2"):
        run_campaign(d, samples=1, seed=1, workers=1, out=out, progress=False)


def test_parquet_next_to_the_csv(tmp_path: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet", reason="Parquet needs pyarrow (redservo[parquet])")
    pd = pytest.importorskip("pandas")
    res = run_campaign(quick(), samples=2, seed=0, workers=1, out=tmp_path, progress=False)
    table = pq.read_table(tmp_path / "samples.parquet")
    schema = table.schema
    assert str(schema.field("sample").type) == "int64" and not schema.field("sample").nullable
    assert str(schema.field("success").type) == "bool"
    assert str(schema.field("min_margin").type) == "double"
    assert schema.field("limit_axis").nullable and str(schema.field("method").type) == "string"
    assert schema.metadata[b"fingerprint"].decode() == res.to_dict()["fingerprint"]
    frame, csv = table.to_pandas(), pd.read_csv(tmp_path / "samples.csv")
    # The CSV's last column is each row's check (rowfile.SEAL_COLUMN); the Parquet mirror,
    # written from the checked rows, carries the fingerprint in its metadata instead.
    assert list(csv.columns)[-1] == "row_check"
    assert list(frame.columns) == list(csv.columns)[:-1] and len(frame) == len(csv) == 4
    assert np.allclose(frame["q0_x"], csv["q0_x"])


def test_limit_axis_is_zero_based_like_the_summary(tmp_path: Path) -> None:
    """One joint numbering: the CSV's limit_axis is summary.json's limit_hit.axis (0-based)."""
    from redservo.campaign.storage import _summary_columns

    summary = {
        "outcome": "joint_limit",
        "iterations": 3,
        "limit_hit": {"axis": 0, "iteration": 2},
        "min_margin": 0.0,
        "max_joint_speed": [0.1],
        "max_camera_speed": {"translation": 0.0, "rotation": 0.0},
        "discontinuity": 0.0,
        "final_error_norm": 0.1,
    }
    row = _summary_columns(summary, ("x", "y"))
    assert row["limit_axis"] == 0 and row["limit_joint"] == "x"


# --------------------------------------------------------------------------- completeness

QUICK_METHODS = ("classical", "iterative-smooth")


def _dropping_sample(monkeypatch: pytest.MonkeyPatch, lost: int) -> None:
    """Make the engine lose the job of sample ``lost`` silently (as the Dask engine once
    did: it pulled one job too many out of the queue and dropped it)."""
    from redservo.campaign import client

    real = client.execute

    def dropping(jobs: Any, engine: Any, on_result: Any) -> None:
        real((j for j in jobs if all(i != lost for i, _ in j.samples)), engine, on_result)

    monkeypatch.setattr(client, "execute", dropping)


def test_a_lost_job_is_named_and_the_campaign_resumes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The client counts the rows of every (sample, method) at the end: an engine that loses
    a job cannot end a campaign as if it were complete. The error names the sample, the rows
    computed are stored, campaign.md states the N actually completed, and a rerun computes
    only the missing runs."""
    import json

    from redservo.campaign import CampaignIncompleteError

    d, out = quick(), tmp_path / "c"
    _dropping_sample(monkeypatch, 1)
    with pytest.raises(CampaignIncompleteError) as info:
        run_campaign(d, samples=3, seed=1, workers=1, out=out, progress=False)
    err = info.value
    assert err.missing == tuple((1, m) for m in QUICK_METHODS)
    text = str(err)
    assert "2 of 6 runs missing: sample 1 (every method)" in text, text
    assert "resumable" in text and str(out / "samples.csv") in text, text
    assert sorted(_csv_keys(out / "samples.csv")) == [(i, m) for i in (0, 2) for m in QUICK_METHODS]
    md = (out / "campaign.md").read_text()
    assert "N = 3 samples per method" not in md
    assert "N completed per method: classical 2, iterative-smooth 2 (of the 3 samples" in md
    meta = json.loads((out / "campaign.json").read_text())
    assert meta["complete"] is False and meta["completed"] == dict.fromkeys(QUICK_METHODS, 2)
    assert err.result is not None and err.result.stats["classical"].runs == 2
    assert err.result.markdown == md and not err.result.complete
    # Without an output directory nothing is stored, and the error says so.
    with pytest.raises(CampaignIncompleteError, match="nothing was stored"):
        run_campaign(d, samples=3, seed=1, workers=1, progress=False)
    monkeypatch.undo()
    full = run_campaign(d, samples=3, seed=1, workers=1, out=out, progress=False)
    assert full.computed == 2 and full.complete
    assert "N = 3 samples per method" in full.markdown
    assert _strip(full.rows) == _strip(run_campaign(d, samples=3, seed=1, workers=1).rows)


def test_an_incomplete_campaign_exits_2_with_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from redservo.cli.entry import main

    path, out = tmp_path / "c.toml", tmp_path / "out"
    path.write_text(CAMPAIGN.format(samples=3))
    _dropping_sample(monkeypatch, 2)
    argv = ["campaign", str(path), "--out", str(out), "--workers", "1", "-q"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("redservo: error: campaign"), err
    assert "sample 2 (every method)" in err[0] and "rerun the same command" in err[0]
    monkeypatch.undo()
    assert main(argv) == 0
    assert len(_csv_keys(out / "samples.csv")) == 3 * len(QUICK_METHODS)


def test_missing_runs_in_words() -> None:
    from redservo.campaign.complete import describe_missing, missing_runs

    present = {(0, "a"), (0, "b"), (1, "b"), (3, "a"), (3, "b")}
    missing = missing_runs(present, 5, ("a", "b"))
    assert missing == [(1, "a"), (2, "a"), (2, "b"), (4, "a"), (4, "b")]
    assert describe_missing(missing, ("a", "b")) == "samples 2, 4 (every method); sample 1 (a)"
    many = missing_runs(set(), 40, ("a",))
    assert describe_missing(many, ("a",)) == (
        "samples 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11 and 28 more (every method)"
    )


def test_a_dead_local_worker_stops_the_campaign_with_the_rows_kept(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A local worker process that dies (here: exits during sample 1) breaks the pool: the
    campaign stops with CampaignIncompleteError, not an internal error, and resumes."""
    import os

    from redservo.campaign import CampaignIncompleteError
    from redservo.campaign import task as campaign_task

    real = campaign_task._run_task

    def dying(task: Any) -> dict[str, Any]:
        if task.sample == 1:
            os._exit(3)  # as if killed (forked workers inherit this patch)
        return real(task)

    monkeypatch.setattr(campaign_task, "_run_task", dying)
    d, out = quick(), tmp_path / "c"
    with pytest.raises(CampaignIncompleteError, match="a local worker process died") as info:
        run_campaign(d, samples=3, seed=1, workers=2, out=out, progress=False)
    assert {(1, m) for m in QUICK_METHODS} <= set(info.value.missing)
    monkeypatch.undo()
    stored = len(_csv_keys(out / "samples.csv"))
    full = run_campaign(d, samples=3, seed=1, workers=1, out=out, progress=False)
    assert full.complete and full.computed == 6 - stored


# --------------------------------------------------------------------------- processes

CAMPAIGN = """
scenario = "afma6-gaze-demo"
methods = ["classical", "iterative-smooth"]
samples = {samples}
[overrides]
simulation = {{ max_iterations = 40 }}
[target]
translation = [0.05, 0.05, 0.05]
"""


def _campaign_cmd(path: Path, out: Path, *extra: str, hold_from: int | None = None) -> list[str]:
    """``redservo campaign`` in a fresh interpreter (without the figures, to keep it quick).

    With ``hold_from``, the runs of samples >= hold_from never end (until the process is
    killed), so that a test can kill the campaign mid-run at a moment it chooses rather than
    at a time that races the workers' start (the pool's workers are forked: they inherit it).
    """
    import sys

    hold = (
        "import threading; from redservo.campaign import task; _real = task._run_task; "
        "_never = threading.Event(); "
        f"task._run_task = lambda t: _never.wait() if t.sample >= {hold_from} else _real(t); "
        if hold_from is not None
        else ""
    )
    code = (
        f"import sys; sys.modules['matplotlib'] = None; {hold}from redservo.cli.entry import main; "
        "sys.exit(main(sys.argv[1:]))"
    )
    args = ["campaign", str(path), "--out", str(out), "-q", *extra]
    return [sys.executable, "-c", code, *args]


def _processes_mentioning(token: str) -> list[int]:
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                cmd = (entry / "cmdline").read_bytes()
            except OSError:
                continue
            if token.encode() in cmd:
                pids.append(int(entry.name))
    return pids


def _wait_for(what: str, ready: Any, proc: Any, bound: float = 180.0) -> None:
    """Poll ``ready()`` (bounded, generously: the machine may be loaded); fail if ``proc``
    ended first."""
    import time

    deadline = time.monotonic() + bound
    while not ready():
        assert proc.poll() is None, f"the campaign ended (rc {proc.returncode}) before {what}"
        assert time.monotonic() < deadline, f"{what}: not within {bound:g} s"
        time.sleep(0.05)


@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs /proc (Linux)")
def test_killed_campaigns_leave_no_orphans_and_one_row_per_pair(tmp_path: Path) -> None:
    """SIGKILL the parent mid-run, with its two workers alive and busy: they exit, and
    resuming leaves exactly one row per (sample, method).

    The kills are placed, not timed: the workers hold the runs of a chosen sample onward, and
    the parent is killed once both workers are seen alive and the rows before that sample
    are stored (earlier, a random kill time raced the workers' start under load)."""
    import signal
    import subprocess
    import time

    path, out = tmp_path / "c.toml", tmp_path / "out-killed"
    path.write_text(CAMPAIGN.format(samples=12))
    csv, token = out / "samples.csv", str(out)
    pairs = {(i, m) for i in range(12) for m in ("classical", "iterative-smooth")}
    for hold_from in (3, 8):  # two kills, each with rows of earlier samples already stored
        cmd = _campaign_cmd(path, out, "--workers", "2", hold_from=hold_from)
        proc = subprocess.Popen(cmd, stderr=subprocess.DEVNULL)
        try:
            _wait_for(
                "the parent and its two workers",
                lambda: len(_processes_mentioning(token)) >= 3,
                proc,
            )
            before = {(i, m) for i, m in pairs if i < hold_from}
            _wait_for(
                f"the rows of samples 0-{hold_from - 1}",
                lambda: csv.exists() and before <= set(_csv_keys(csv)),  # noqa: B023
                proc,
            )
            assert len(_processes_mentioning(token)) >= 3, "the workers exited before the kill"
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
        deadline = time.monotonic() + 60.0  # generous: the workers die with their parent
        while _processes_mentioning(token) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _processes_mentioning(token) == [], f"orphans after the kill at {hold_from}"
        keys = _csv_keys(csv)
        assert len(keys) == len(set(keys)), f"duplicates after the kill at {hold_from}"
        assert not {k for k in keys if k[0] >= hold_from}, "a held run was stored"
    done = subprocess.run(
        _campaign_cmd(path, out, "--workers", "2"), capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    assert sorted(_csv_keys(csv)) == sorted(pairs)


def test_two_concurrent_writers(tmp_path: Path) -> None:
    """Two campaigns started together on one directory: one waits for the other (--wait), the
    second reuses the first's rows, and the file has exactly one row per (sample, method).
    (Without --wait the second stops at once: test_the_output_directory_is_locked.)"""
    import subprocess

    path, out = tmp_path / "c.toml", tmp_path / "out-shared"
    path.write_text(CAMPAIGN.format(samples=4))
    cmd = _campaign_cmd(path, out, "--workers", "1", "--wait")
    procs = [
        subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    errs = [p.communicate(timeout=120)[1] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], errs
    keys = _csv_keys(out / "samples.csv")
    assert sorted(keys) == sorted(
        {(i, m) for i in range(4) for m in ("classical", "iterative-smooth")}
    )


def test_documented_campaign_example_parses() -> None:
    """docs/campaigns.md's example is a valid campaign file."""
    import re

    text = (Path(__file__).resolve().parents[1] / "docs" / "campaigns.md").read_text()
    block = re.search(r"```toml\n(.*?)```", text, re.S)
    assert block is not None
    d = parse_campaign(tomllib.loads(block.group(1)), "docs/campaigns.md")
    assert d.methods == ("classical", "gpm") and d.start.joints == ("x", "z", "B")
    assert d.target.translation[2] == (-0.1, 0.3) and d.errors.depth_scale == (0.7, 1.3)


# --------------------------------------------------------------------------- memory


def _fake_engine(monkeypatch: pytest.MonkeyPatch, per_result: int = 250) -> None:
    """Replace the engine by one that makes a complete row per (sample, method) at once,
    without simulating (so only the client's own memory is measured)."""
    from redservo.campaign import client
    from redservo.campaign.engine import JobResult
    from redservo.campaign.rows import _columns

    defaults = {"float": 0.5, "int": 1, "int?": None, "str": "", "bool": True}

    def fake(jobs: Any, engine: Any, on_result: Any) -> None:
        template: dict[str, Any] | None = None
        batch: list[dict[str, Any]] = []
        for job in jobs:
            if template is None:
                cols = _columns(job.definition.nominal.joint_names)
                template = {c: defaults[k] for c, k in cols}
                template.update(outcome="converged", flags="shield-acted")
            for i, methods in job.samples:
                for m in methods:
                    batch.append({**template, "sample": i, "method": m, "iterations": 10 + i % 7})
            if len(batch) >= per_result:
                on_result(JobResult(batch, {}))
                batch = []
        if batch:
            on_result(JobResult(batch, {}))

    monkeypatch.setattr(client, "execute", fake)


def _looks_like_row(obj: Any) -> bool:
    return isinstance(obj, dict) and "outcome" in obj and "max_cam_rotation" in obj


def test_the_client_keeps_no_row_dicts_and_its_memory_per_run_is_small(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """docs/scaling.md, "Memory": rows go to samples.csv as they finish and are read back
    lazily; the client keeps a few numpy columns and an index (under 1 kB per run; a row
    dict alone is over 2 kB, and the client kept two copies of each before). Measured with tracemalloc on a fake engine (not time)."""
    import gc
    import tracemalloc

    _fake_engine(monkeypatch)
    d = quick(methods=["classical"])
    assert d.nominal is not None  # evaluated (and cached) outside the measurement
    peaks, results = {}, {}
    for n in (1500, 6000):  # both above the rows per row group of samples.parquet
        gc.collect()
        tracemalloc.start()
        res = run_campaign(d, samples=n, seed=0, workers=1, out=tmp_path / f"n{n}", progress=False)
        peaks[n] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        results[n] = res
        assert res.complete and len(res.rows) == n and res.stats["classical"].successes == n
    gc.collect()
    kept = sum(_looks_like_row(o) for o in gc.get_objects())
    assert kept == 0, f"{kept} row dicts kept in memory after the campaigns"
    per_run = (peaks[6000] - peaks[1500]) / 4500
    assert per_run < 1500, f"the client's peak grows by {per_run:.0f} B per run"
    # The rows still read back, in order, identical to the file's.
    rows = results[6000].rows
    assert [r["sample"] for r in rows[:3]] == [0, 1, 2] and rows[-1]["sample"] == 5999
    assert rows[7]["iterations"] == 10 + 7 % 7 and rows[7]["flags"] == "shield-acted"
    assert sum(1 for _ in rows) == 6000


def test_rows_without_an_output_directory_live_in_a_temporary_file(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Without ``out`` the rows go to a temporary file that is removed with the result."""
    import gc

    _fake_engine(monkeypatch)
    res = run_campaign(quick(methods=["classical"]), samples=40, seed=0, workers=1, progress=False)
    path = res.rows.path  # type: ignore[attr-defined]
    assert path.exists() and len(res.rows) == 40 and res.rows[39]["sample"] == 39
    del res
    gc.collect()
    assert not path.exists()


def test_rows_of_a_rewritten_file_are_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A result's rows point into samples.csv: if the file was rewritten since, reading a
    row says so instead of returning another (sample, method)'s row."""
    _fake_engine(monkeypatch)
    res = run_campaign(quick(), samples=4, seed=0, workers=1, out=tmp_path, progress=False)
    csv = tmp_path / "samples.csv"
    lines = csv.read_text().splitlines(keepends=True)
    csv.write_text(lines[0] + "".join(reversed(lines[1:])))
    with pytest.raises(ConfigurationError, match="changed since the campaign ended"):
        list(res.rows)
