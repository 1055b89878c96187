"""The short paths of a common frame (every dot predicted, found and finite) give what the
general code gives, bit for bit, on fuzzed inputs: the tracker's predicted moves, the dots'
normalized coordinates, a term's dots (issue 28, image campaigns' speed)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.vision.measure import measured_dots
from redservo.vision.motion import normalized_dots
from redservo.vision.optics import Optics
from redservo.vision.sensor import _all_seen
from redservo.vision.tracking import ImageDotTracker, _Dot


def _tracker(rng: np.random.Generator, n: int) -> ImageDotTracker:
    tr = ImageDotTracker(n)
    tr._dots = [_Dot(rng.uniform(0, 640, 2), rng.normal(0, 3, 2)) for _ in range(n)]
    return tr


def test_the_predicted_moves_are_the_general_codes() -> None:
    rng = np.random.default_rng(0)
    for k in range(500):
        n = int(rng.integers(1, 9))
        tr = _tracker(rng, n)
        shift = rng.normal(0.0, 10.0 ** rng.uniform(-3, 2), (n, 2))
        if k % 3 == 0:
            shift[rng.integers(0, n), rng.integers(0, 2)] = np.nan
        vel = np.array([d.vel for d in tr._dots])
        want = np.where(np.isnan(shift).any(axis=1, keepdims=True), vel, shift)
        got = tr._moves(shift)
        assert got.tobytes() == want.tobytes() and got is not shift
    shift[0, 0] = np.inf
    with pytest.raises(ConfigurationError, match="shift must be finite"):
        tr._moves(shift)


@pytest.mark.parametrize("k1", [0.0, -0.2])
def test_the_normalized_dots_are_the_optics(k1: float) -> None:
    rng = np.random.default_rng(1)
    optics = Optics(Camera(px=612.5, py=598.0, u0=331.7, v0=236.1), k1=k1)
    for _ in range(200):
        uv = rng.uniform(-100.0, 800.0, (int(rng.integers(0, 9)), 2))
        if len(uv) and rng.random() < 0.3:
            uv[rng.integers(0, len(uv)), 0] = rng.choice([np.nan, np.inf])
        with np.errstate(invalid="ignore"):  # inf through the distortion's iteration
            assert normalized_dots(optics, uv).tobytes() == optics.to_normalized(uv).tobytes()


def test_a_terms_dots_are_the_general_codes_on_a_frame_where_all_were_seen() -> None:
    rng = np.random.default_rng(2)
    for _ in range(300):
        n = int(rng.integers(1, 9))
        xy = rng.normal(0.0, 0.3, (n, 2))
        detected = rng.random(n) < 0.9
        if rng.random() < 0.2:
            xy[rng.integers(0, n), 1] = np.nan
        dots = np.sort(rng.choice(n, size=int(rng.integers(1, n + 1)), replace=False))
        sensor = SimpleNamespace(_detected=detected, all_dots_seen=_all_seen(detected, xy))
        general = SimpleNamespace(_detected=detected)
        st, st_ref = SimpleNamespace(dots=dots), SimpleNamespace(dots=dots)
        notes: list[str] = []
        notes_ref: list[str] = []
        got = measured_dots(sensor, st, xy, notes, 3)  # type: ignore[arg-type]
        want = measured_dots(general, st_ref, xy, notes_ref, 3)  # type: ignore[arg-type]
        assert (got is None) == (want is None)
        if got is not None and want is not None:
            assert got.tobytes() == want.tobytes()
        assert st.lost_dots == st_ref.lost_dots and notes == notes_ref
