"""A campaign's per-sample and per-run work outside the loop (docs/scaling.md, 2026-11-29,
third pass): the run's summary reduced in one kernel call (the bits of ``summarize``), a
sample's experiment built from what changes (``build``'s experiment), a row's values kept for
the statistics without formatting and parsing it back (the values of its line)."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

pytest.importorskip("numba", reason="the compiled campaign loop needs numba (redservo[fast])")

from redservo.campaign import fastloop, load_campaign, run_campaign
from redservo.campaign.loop_summary import loop_summary, pairwise_sum
from redservo.campaign.rowfile import format_line, parse_line
from redservo.campaign.rows import _columns, _error_columns, stored
from redservo.campaign.sample_build import sample_experiment
from redservo.campaign.sampling import _draw
from redservo.errors import ScenarioError
from redservo.limits import JointLimits
from redservo.records import SimulationLog, summarize
from redservo.redundancy.flags import FLAGS


def _log(logs: tuple[Any, ...], rows: int, dt: float) -> SimulationLog:
    """The log ``fastloop._summary`` builds from the loop's buffers (the object path's)."""
    Q, QD, TW, EN, FL = (b[:rows] for b in logs)
    n = Q.shape[1]
    bits = (FL[:, None] >> np.arange(len(FLAGS))) & 1
    zeros, nan, zn = np.zeros(rows), np.full(rows, np.nan), np.zeros((rows, n))
    return SimulationLog(
        t=np.arange(rows) * dt,
        q=Q,
        qdot=QD,
        camera_twist=TW,
        s=np.zeros((rows, 0)),
        e=np.zeros((rows, 0)),
        e1=np.zeros((rows, 0)),
        error_norm=EN,
        q_normalized=zn,
        alpha=nan,
        projector_rank=zeros,
        task_rank=zeros,
        levels=zeros,
        overconstrained=zeros,
        constrained=zn,
        gamma=zn,
        scale=nan,
        flags=np.where(bits != 0, 1.0, np.nan),
    )


class _Exp:
    """What the reduced summary reads of an experiment (weakly referenced, as one is)."""

    def __init__(self, limits: JointLimits, options: Any, robot: Any) -> None:
        self.limits, self.options, self.robot = limits, options, robot


@pytest.mark.parametrize("n", [2, 6, 7, 8, 9, 17, 40, 150])
def test_the_reduced_summary_has_the_bits_of_summarize(n: int) -> None:
    """Random logs of every joint count around numpy's summation blocks (8, 128), with
    NaN, ties at the limits and velocity and acceleration excesses: the same summary."""
    rng = np.random.default_rng(n)
    for trial in range(12):
        rows = int(rng.integers(1, 260))
        q_min, q_max = -rng.uniform(0.5, 3.0, n), rng.uniform(0.5, 3.0, n)
        vel = rng.uniform(0.2, 2.0, n) if trial % 3 else None
        acc = rng.uniform(1.0, 20.0, n) if trial % 4 else None
        limits = JointLimits(q_min, q_max, rho=0.1, qdot_max=vel, qddot_max=acc)
        scale = 10.0 ** rng.integers(-6, 3, (rows, n))
        Q = np.clip(rng.uniform(q_min, q_max, (rows, n)), q_min, q_max)
        Q[rng.random((rows, n)) < 0.02] = q_max[0] if n == 1 else Q[0, 0]
        QD = rng.standard_normal((rows, n)) * scale
        TW = rng.standard_normal((rows, 6)) * 10.0 ** rng.integers(-6, 3, (rows, 6))
        EN = rng.uniform(0.0, 1.0, rows)
        FL = rng.integers(0, 2 ** len(FLAGS), rows) * (rng.random(rows) < 0.3)
        if trial % 5 == 4:
            QD[rng.integers(rows), rng.integers(n)] = np.nan
            TW[rng.integers(rows), rng.integers(6)] = np.nan
        logs = (Q, QD, TW, EN, FL.astype(np.int64))
        opts = SimpleNamespace(dt=0.04, min_margin=0.01)
        exp = _Exp(limits, opts, SimpleNamespace(n=n))
        outcome = "converged" if trial % 2 else "max_iterations"
        got = loop_summary(exp, rows, outcome, None, logs)
        want = summarize(_log(logs, rows, 0.04), outcome, limits, None, dt=0.04, min_margin=0.01)
        assert got is not None
        assert repr(got.to_dict()) == repr(want.to_dict()), (n, trial)


def test_pairwise_sum_is_numpys_order() -> None:
    rng = np.random.default_rng(3)
    for n in (*range(1, 40), 127, 128, 129, 255, 256, 300, 1000):
        x = rng.standard_normal(n) * 10.0 ** rng.integers(-8, 8, n)
        assert pairwise_sum(x, 0, n) == np.add.reduce(x) or (n == 0), n


def test_covered_runs_do_not_call_summarize(monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled runs of a campaign take the reduced summary, not a log and summarize
    (their rows are those of the object path: tests/test_campaign_fast.py)."""

    def refused(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("summarize called for a covered run")

    monkeypatch.setattr(fastloop, "summarize", refused)
    res = run_campaign(
        "cm01-gaze", samples=2, methods=["classical", "qp"], workers=1, progress=False
    )
    assert res.engines == {"classical": {"compiled loop": 2}, "qp": {"compiled loop": 2}}
    assert all(r["error"] == "" for r in res.rows)


def _same(a: Any, b: Any, path: str) -> None:
    """``a`` and ``b`` hold the same values, arrays bit for bit (objects field by field)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes(), path
    elif isinstance(a, list | tuple):
        assert isinstance(b, list | tuple) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{path}[{i}]")
    elif isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), path
        for k in a:
            _same(a[k], b[k], f"{path}[{k!r}]")
    elif type(a).__module__.startswith("redservo") and hasattr(a, "__dict__"):
        assert type(a) is type(b), path
        for k, v in vars(a).items():
            _same(v, vars(b)[k], f"{path}.{k}")
    elif hasattr(a, "__dataclass_fields__"):
        for k in a.__dataclass_fields__:
            _same(getattr(a, k), getattr(b, k), f"{path}.{k}")
    elif not callable(a):
        assert a == b or (a != a and b != b), path


@pytest.mark.parametrize(
    "name", ["afma6-gaze-demo", "cm01-humanoid-tracking", "mc05-joint-limits", "panda-posts"]
)
def test_a_sample_experiment_is_builds(name: str) -> None:
    """A sample's experiment with the shared parts built once is ``build``'s, field by field."""
    from redservo.experiment.build import build

    d = load_campaign(name)
    for i in range(3):
        sc = _draw(d, 0, i, 0).scenario
        try:
            want = build(sc)
        except ScenarioError as exc:  # an invalid draw: the same error, the same words
            with pytest.raises(ScenarioError) as got_exc:
                sample_experiment(d, sc)
            assert str(got_exc.value) == str(exc)
            continue
        got = sample_experiment(d, sc)
        for f in ("robot", "law", "q0", "limits", "scene", "task", "options", "camera"):
            _same(getattr(got, f), getattr(want, f), f"{name}[{i}].{f}")
        for f in ("sensor", "actuator", "obstacles", "timing"):
            _same(getattr(got, f), getattr(want, f), f"{name}[{i}].{f}")


def test_the_robot_is_built_once_per_definition(monkeypatch: pytest.MonkeyPatch) -> None:
    """The samples of a campaign share the robot, its limits, the camera and the law."""
    import redservo.experiment.robot as robot_module

    built = [0]
    real = robot_module.scenario_robot

    def counted(*args: Any) -> Any:
        built[0] += 1
        return real(*args)

    monkeypatch.setattr(robot_module, "scenario_robot", counted)
    d = load_campaign("afma6-gaze-demo")
    assert d.nominal is not None  # the definition's own build, once
    built[0] = 0
    exps = [sample_experiment(d, _draw(d, 0, i, 0).scenario) for i in range(4)]
    assert built[0] == 1 and all(e.robot is exps[0].robot for e in exps)


def test_stored_values_are_those_the_line_reads_back() -> None:
    """A row's values kept for the statistics are those of its line in ``samples.csv``."""
    columns = _columns(("a", "b"))
    nan = float("nan")
    base: dict[str, Any] = {c: 0 for c, _ in columns}
    base.update(sample=3, method="gpm", near_joints="a+b", reachable="True", flags="x;y")
    rows = [
        {**base, "outcome": "converged", "success": True, "min_margin": 0.1 + 0.2},
        {**base, "limit_axis": np.int64(1), "limit_iteration": 7, "min_distance": nan},
        {**base, "q0_a": np.float64(-0.0), "final_error": 1e-300, "limit_axis": None},
        {**base, **_error_columns(ValueError('bad "quoted", value\nnext line'))},
    ]
    for row in rows:
        want = parse_line(columns, format_line(columns, row).encode())
        got = stored(columns, row)
        assert want is not None
        assert {k: repr(v) for k, v in got.items()} == {k: repr(v) for k, v in want.items()}
        assert all(type(got[k]) is type(want[k]) for k in want)


def test_the_client_does_not_parse_rows_back(monkeypatch: pytest.MonkeyPatch) -> None:
    """The statistics take a computed row's values as they are (no format and parse)."""
    import redservo.campaign.rowfile as rowfile

    def refused(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("a computed row parsed back")

    import redservo.campaign.client as client

    monkeypatch.setattr(rowfile, "parse_line", refused)
    monkeypatch.setattr(client, "parse_line", refused, raising=False)
    res = run_campaign("cm01-gaze", samples=2, methods=["classical"], workers=1, progress=False)
    assert res.stats["classical"].runs == 2 and not math.isnan(res.stats["classical"].success_rate)


def test_a_batch_formats_as_its_lines_one_by_one() -> None:
    """One CSV writer for a batch writes each row's own line (quotes, newlines, the seal)."""
    from redservo.campaign.rowfile import format_lines

    columns = _columns(("a",))
    base: dict[str, Any] = {c: 1 for c, _ in columns}
    rows = [
        {**base, "method": "gpm", "min_margin": 0.1 + 0.2},
        {**base, **_error_columns(ValueError('a "quoted", value'))},
        {**base, "near_joints": "", "limit_axis": None},
    ]
    for seal in (None, "f" * 64):
        assert format_lines(columns, rows, seal) == [format_line(columns, r, seal) for r in rows]
