"""Robust dots (issue 19): nested targets, printed digits, and tracking through the failure modes.

The sequences (:mod:`redservo.vision.dotseq`) are small (160 x 120, at most 60
frames) with noise σ = 2 gray levels and blur 0.7 px; the full-size numbers are
in benchmarks/bench_vision.py and docs/vision.md.
"""

from __future__ import annotations

import numpy as np
import pytest

from redservo.camera import Camera

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.vision.dots import detect_dots  # noqa: E402
from redservo.vision.dotseq import SEQUENCE_KINDS, _paint_disc, dot_sequence  # noqa: E402
from redservo.vision.ellipse import detect_ellipse  # noqa: E402
from redservo.vision.optics import Optics  # noqa: E402
from redservo.vision.sources import track_dots  # noqa: E402
from redservo.vision.tracking import LOSS_REASONS, ImageDotTracker  # noqa: E402

R_DOT = 3.5  # the sequences' dot radius at 160 x 120 (pixels)


def _run(kind: str, n: int = 60) -> tuple[list, list]:
    tracker = ImageDotTracker(4)
    frames, states = [], []
    for k, fr in enumerate(dot_sequence(kind, n)):
        states.append(tracker.start(fr.image, fr.uv) if k == 0 else tracker.update(fr.image))
        frames.append(fr)
    return frames, states


@pytest.mark.parametrize("kind", SEQUENCE_KINDS)
def test_tracker_finds_every_visible_dot_inside_its_blob(kind: str) -> None:
    frames, states = _run(kind)
    visible = np.array([f.visible for f in frames])
    found = np.array([s.detected for s in states])
    assert (found & visible).sum() >= 0.99 * visible.sum(), f"{kind}: dots missed"
    if kind != "bright_merge":  # there a dot 0-2 px from the band may still be separable
        assert not (found & ~visible).any(), f"{kind}: a hidden dot was 'found'"
    for i in range(4):  # re-acquired within 3 frames of reappearing (occlusion, merge)
        back = [k for k in range(1, len(frames)) if visible[k, i] and not visible[k - 1, i]]
        for k in back:
            assert found[k : k + 4, i].any(), f"{kind}: dot {i} not re-acquired after frame {k}"
    err = np.array([np.hypot(*(s.uv - f.uv).T) for f, s in zip(frames, states)])[found]
    # Never a centroid outside its blob: always within the dot's disc.
    assert err.max() < R_DOT, f"{kind}: a centroid left its dot ({err.max():.2f} px)"
    if kind == "bright_crossing":
        # Known limit (docs/vision.md): the brighter background's edge hidden under
        # a straddling dot biases its centroid.
        assert err.max() <= 0.6
    else:
        assert np.sqrt(np.mean(err**2)) <= 0.1, f"{kind}: centroid RMS {err.std():.3f} px"


def test_occluded_dot_is_lost_with_a_reason_then_reacquired_at_once() -> None:
    frames, states = _run("occlusion")
    hidden = [k for k, f in enumerate(frames) if not f.visible[2]]
    assert len(hidden) == 10
    for k in hidden:
        assert not states[k].detected[2]
        assert states[k].reasons[2] in LOSS_REASONS and states[k].reasons[2] != ""
    back = hidden[-1] + 1
    assert states[back].detected.all() or states[back + 2].detected.all()
    first_found = next(k for k in range(back, len(states)) if states[k].detected[2])
    assert first_found - back <= 3
    assert np.hypot(*(states[first_found].uv[2] - frames[first_found].uv[2])) < 0.2


def test_a_dot_leaving_the_image_is_at_border_then_out_of_image() -> None:
    tracker = ImageDotTracker(1, max_jump_px=10.0)
    reasons = []
    for k in range(30):
        img = np.full((60, 80), 30.0, np.float32)
        _paint_disc(img, np.array([50.0 + 2.0 * k, 30.0]), 3.0, 220.0)
        img8 = np.clip(img, 0, 255).astype(np.uint8)
        st = tracker.start(img8, [[50.0, 30.0]]) if k == 0 else tracker.update(img8)
        reasons.append(st.reasons[0])
    assert reasons[0] == "" and reasons[5] == ""
    assert "at_border" in reasons and reasons[-1] == "out_of_image"
    assert reasons.index("at_border") < reasons.index("out_of_image")


def test_nested_target_with_a_border_is_found_by_detect_dots() -> None:
    fr = next(iter(dot_sequence("nested", 1)))
    det = detect_dots(fr.image)  # Otsu: the paper and the dots are both "bright"
    assert det.uv.shape == (4, 2)
    d = np.linalg.norm(fr.uv[:, None] - det.uv[None], axis=2).min(axis=1)
    assert d.max() < 0.1


def test_printed_digits_are_not_dots() -> None:
    # A calibration grid: dark dots, with dark printed digits beside some of them.
    img = np.full((200, 260), 215.0, np.float32)
    centres = [np.array([40.0 + 60 * i, 40.0 + 60 * j]) for i in range(4) for j in range(3)]
    for c in centres:
        _paint_disc(img, c, 7.0, 25.0)
    ink = np.zeros(img.shape, np.uint8)
    for n, c in enumerate(centres):
        org = (int(c[0] + 12), int(c[1] + 22))
        cv2.putText(ink, str(n), org, cv2.FONT_HERSHEY_SIMPLEX, 0.6, 255, 2, cv2.LINE_AA)
    a = ink / 255.0
    img = img * (1 - a) + 25.0 * a + np.random.default_rng(0).normal(0, 2.0, img.shape)
    det = detect_dots(np.clip(img, 0, 255).astype(np.uint8), polarity="dark")
    assert det.uv.shape == (12, 2)
    assert det.n_rejected >= 10
    d = np.linalg.norm(np.array(centres)[:, None] - det.uv[None], axis=2).min(axis=1)
    assert d.max() < 0.1


def test_centroids_stay_in_the_image_and_in_their_blob_on_random_images() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        img = cv2.GaussianBlur(rng.integers(0, 256, (48, 64), dtype=np.uint8), (0, 0), 1.5)
        mask = img > 128
        det = detect_dots(img, threshold=128.0, shape=None, size_consistency=None)
        for u, v in det.uv:
            assert 0.0 <= u <= 64.0 and 0.0 <= v <= 48.0
            assert mask[int(v) - 1 : int(v) + 2, int(u) - 1 : int(u) + 2].any()


def test_track_dots_reports_typed_reasons_and_reacquires() -> None:
    seq = list(dot_sequence("occlusion", 45))
    got = track_dots([f.image for f in seq], initial_uv=seq[0].uv)
    hidden = [k for k, f in enumerate(seq) if not f.visible[2]]
    assert all(got[k].reasons[2] in LOSS_REASONS for k in hidden)
    assert "dot(s) 2 (" in got[hidden[0]].reason
    assert all(fr.detected.all() for fr in got[hidden[-1] + 2 :])


def test_ellipse_inside_a_dark_square_on_bright_paper() -> None:
    img = np.full((120, 160), 210.0, np.float32)
    img[30:90, 50:110] = 20.0
    _paint_disc(img, np.array([80.3, 60.6]), 12.0, 220.0)
    img8 = np.clip(img, 0, 255).astype(np.uint8)
    meas, why = detect_ellipse(img8, Optics(Camera()), near_uv=(78.0, 58.0))
    assert meas is not None, why  # RETR_EXTERNAL saw only the paper
    assert np.hypot(meas.uv[0] - 80.3, meas.uv[1] - 60.6) < 0.05


def _frame(discs: list[tuple[float, float]], r: float = 3.5) -> np.ndarray:
    img = np.full((120, 160), 35.0, np.float32)
    for u, v in discs:
        _paint_disc(img, np.array([u, v]), r, 225.0)
    return np.clip(img + np.random.default_rng(len(discs)).normal(0, 2, img.shape), 0, 255).astype(
        np.uint8
    )


def test_a_lone_dot_is_reacquired_in_a_growing_window() -> None:
    # No other dot to predict it from: the window around its coasting prediction
    # grows each frame it stays lost until it holds the dot, 90 px away.
    tracker = ImageDotTracker(1)
    tracker.start(_frame([(40.0, 60.0)]), [[40.0, 60.0]])
    found_at = None
    for k in range(1, 8):
        st = tracker.update(_frame([] if k < 3 else [(130.0, 60.0)]))
        if k < 3:
            assert st.reasons[0] == "out_of_window"
        elif st.detected[0]:
            found_at = k
            break
    assert found_at is not None and found_at - 3 <= 3
    assert np.hypot(*(st.uv[0] - [130.0, 60.0])) < 0.1


def test_reacquisition_respects_the_geometry_of_the_other_dots() -> None:
    square = [(50.0, 30.0), (110.0, 30.0), (110.0, 90.0), (50.0, 90.0)]
    tracker = ImageDotTracker(4)
    tracker.start(_frame(square), square)
    tracker.update(_frame(square))
    decoy = (110.0 - 25.0, 90.0)  # 25 px from dot 2's place, inside its search window
    for _ in range(4):
        st = tracker.update(_frame([*square[:2], square[3], decoy]))
        assert not st.detected[2], "the decoy, off the target's geometry, was taken for dot 2"
        assert st.detected[[0, 1, 3]].all()
    st = tracker.update(_frame([*square, decoy]))
    assert st.detected.all()
    assert np.abs(st.uv - np.array(square)).max() < 0.1


def test_dark_dots_in_white_squares_on_black_paper() -> None:
    # The nested target in negative: the same dots, tracked with polarity "dark".
    tracker = ImageDotTracker(4, polarity="dark")
    for k, fr in enumerate(dot_sequence("nested", 20)):
        img = 255 - fr.image
        st = tracker.start(img, fr.uv) if k == 0 else tracker.update(img)
        assert st.detected.all(), st.reasons
        assert np.abs(st.uv - fr.uv).max() < 0.1
    det = detect_dots(img, polarity="dark")
    assert det.uv.shape == (4, 2)


def test_image_tracker_refuses_bad_input() -> None:
    from redservo.errors import ConfigurationError, ShapeError

    with pytest.raises(ConfigurationError, match="polarity"):
        ImageDotTracker(2, polarity="grey")  # type: ignore[arg-type]
    with pytest.raises(ConfigurationError, match="size_precision"):
        ImageDotTracker(2, size_precision=1.5)
    tracker = ImageDotTracker(2)
    with pytest.raises(ConfigurationError, match="start"):
        tracker.update(np.zeros((10, 10), np.uint8))
    with pytest.raises(ShapeError, match="shape"):
        tracker.start(np.zeros((10, 10), np.uint8), np.zeros((3, 2)))
    with pytest.raises(ShapeError, match="uint8"):
        tracker.start(np.zeros((10, 10)), np.zeros((2, 2)))


def test_a_dot_lost_for_long_stops_coasting_and_is_found_again() -> None:
    # A lone dot moving right at 4 px/frame vanishes for 30 frames: coasting on would
    # carry its prediction out of the image; it stops after max_lost_frames instead.
    tracker = ImageDotTracker(1, max_lost_frames=3)
    tracker.start(_frame([(30.0, 60.0)]), [[30.0, 60.0]])
    for k in range(1, 5):
        st = tracker.update(_frame([(30.0 + 4 * k, 60.0)]))
    assert st.detected[0]
    for _ in range(30):
        st = tracker.update(_frame([]))
        assert not st.detected[0] and st.reasons[0] == "out_of_window"
    assert 0.0 < st.uv[0, 0] < 160.0
    st = tracker.update(_frame([(120.0, 30.0)]))
    assert st.detected[0] and np.hypot(*(st.uv[0] - [120.0, 30.0])) < 0.1
