"""The run's singularity margin reduced in bulk (issue 28, item 6): the same bits as one numpy
SVD and one determinant per step, the code it replaces (kept here as the reference)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.control.manipulability import SingularityMargin


class _PerStep:
    """The margin as it was: numpy's SVD and ``det(J1 J1ᵀ)`` at every step."""

    def __init__(self) -> None:
        self.w, self.sigma = float("inf"), float("inf")

    def add(self, J1: Any) -> None:
        sv = np.linalg.svd(J1, compute_uv=False)
        self.w = min(self.w, float(np.sqrt(max(float(np.linalg.det(J1 @ J1.T)), 0.0))))
        self.sigma = min(self.sigma, float(sv[-1]) if sv.size else 0.0)


def _jacobians(seed: int, steps: int) -> list[Any]:
    """A run's task Jacobians: one shape, entries over decades, rank losses, zeros, ties."""
    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(1, 9)), int(rng.integers(1, 9))
    out = []
    for k in range(steps):
        J = rng.normal(size=(m, n)) * 10.0 ** rng.uniform(-4, 4)
        if k % 7 == 3 and m > 1:
            J[-1] = J[0]  # rank loss: det(J1 J1ᵀ) ~ 0, of either sign
        if k % 11 == 5:
            J[:] = 0.0
        if k % 13 == 8 and out:
            J = out[-1].copy()  # a tie
        out.append(J)
    return out


@pytest.mark.parametrize("seed", range(40))
def test_the_margin_reduced_in_bulk_is_the_per_step_margin(seed: int) -> None:
    """Fuzzed runs (1-8 rows, 1-8 joints, scales over eight decades, rank losses, zero and
    repeated Jacobians), read mid-run and at the end: ``w`` and ``σ_min`` bit for bit."""
    got, want = SingularityMargin(), _PerStep()
    assert got.fields() == {"min_manipulability": None, "min_singular_value": None}
    for k, J in enumerate(_jacobians(seed, 150)):
        got.add(J)
        want.add(J)
        if k % 50 == 17:  # read mid-run: what is kept is reduced, more is added after
            assert (got.w.hex(), got.sigma.hex()) == (want.w.hex(), want.sigma.hex())
    f = got.fields()
    assert f["min_manipulability"].hex() == want.w.hex()
    assert f["min_singular_value"].hex() == want.sigma.hex()
    assert got.steps == 150


def test_a_new_shape_starts_a_new_stack() -> None:
    """Jacobians of another shape (another task) are reduced with their own stack."""
    got, want = SingularityMargin(), _PerStep()
    for J in _jacobians(1, 70) + _jacobians(2, 70):
        got.add(J)
        want.add(J)
    assert (got.w.hex(), got.sigma.hex()) == (want.w.hex(), want.sigma.hex())


def test_a_long_run_keeps_a_bounded_stack() -> None:
    """A full stack (``chunk`` Jacobians) is reduced and reused: the memory of a long run
    stays bounded, and the margin is the per-step one bit for bit."""
    got, want = SingularityMargin(chunk=40), _PerStep()
    for J in _jacobians(5, 300):
        got.add(J)
        want.add(J)
        assert got._stack.shape[0] <= 40
    assert (got.w.hex(), got.sigma.hex()) == (want.w.hex(), want.sigma.hex())
