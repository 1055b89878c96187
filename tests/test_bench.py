"""The benchmark harness runs and reports every method (timings themselves live in benchmarks/)."""

from __future__ import annotations

from redservo.bench import bench_cases, run_bench


def test_bench_reports_every_case_and_the_target_row() -> None:
    res = run_bench(repeat=5, methods=("classical", "iterative-smooth"), throughput_steps=5)
    assert len(res.rows) == 2 * len(bench_cases())
    assert res.target_row() is not None
    assert all(r.full_median > 0 and r.law_median > 0 for r in res.rows)
    md = res.markdown
    assert "SVD unit" in md and "Target (iterative-smooth" in md and "steps/s" in md
