"""``redservo calibrate`` on doubtful input (issue 32): repeated, parallel or small views, the
distortion model chosen and reported, images too small or too large, an unwritable output."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from redservo.calibration.files import load_camera
from redservo.cli.entry import main
from redservo.spatial import make_transform

cv2 = pytest.importorskip("cv2")

from redservo.calibration import calibrate_camera  # noqa: E402
from redservo.calibration.synthetic import render_pattern  # noqa: E402
from tests.test_calibration import TRUE, _views  # noqa: E402
from tests.test_vision_cli import _png_header_only  # noqa: E402

BOARD = ["--chessboard", "9x6", "--square", "0.025"]
CENTRE = np.array([0.1, 0.0625, 0.0])  # the 9x6 board's centre (m)


def _write(folder: Path, poses: list[np.ndarray], prefix: str = "view") -> list[str]:
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for k, cMo in enumerate(poses):
        path = folder / f"{prefix}{k:02d}.png"
        cv2.imwrite(str(path), render_pattern(TRUE, cMo, size=(9, 6), spacing=0.025))
        files.append(str(path))
    return files


@pytest.fixture(scope="module")
def views(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    return _write(tmp_path_factory.mktemp("views"), _views(10, (9, 6), 0.025))


def _one_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return err


def test_copies_of_one_image_are_refused(
    views: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cam.yaml"
    assert main(["calibrate", *[views[0]] * 6, *BOARD, "--out", str(out), "-q"]) == 2
    err = _one_error(capsys)
    assert "found in 6 of 6 image(s) (5 of them repeat another view): 1 distinct view(s)" in err
    assert "at least 3 different views" in err and not out.exists()


def test_repeated_views_are_not_used_and_said(
    views: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cam.yaml"
    argv = ["calibrate", *views, views[3], *BOARD, "--out", str(out), "-q"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert f"{views[3]} repeats {views[3]} (not used)" in captured.err
    assert "over 10 of 11 image(s)" in captured.out
    assert "distortion model k1k2p (auto: 10 distinct views covering 42% of the image" in (
        captured.out
    )
    assert load_camera(out).k3 == 0.0


def test_the_distortion_model_is_chosen_and_reported(
    views: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cam.yaml"
    assert main(["calibrate", *views[:4], *BOARD, "--out", str(out), "-q"]) == 0
    captured = capsys.readouterr()
    assert "distortion model k1 (auto: 4 distinct views" in captured.out
    cam = load_camera(out)
    assert cam.k1 != 0.0 and (cam.k2, cam.p1, cam.p2, cam.k3) == (0.0, 0.0, 0.0, 0.0)
    assert captured.err == ""
    argv = ["calibrate", *views[:4], *BOARD, "--out", str(out), "-q", "--distortion", "full5"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "distortion model full5 (chosen; 4 distinct views" in captured.out
    assert "warning: distortion full5 fits more terms than the views support" in captured.err
    assert load_camera(out).k3 != 0.0
    for model, free in (("none", 0), ("k1k2", 2), ("k1k2p", 4)):
        res = calibrate_camera(
            [cv2.imread(v, cv2.IMREAD_GRAYSCALE) for v in views[:6]], distortion=model
        )
        assert res.model == model and res.model_reason.startswith("chosen")
        assert np.count_nonzero(res.camera.distortion) == free
    assert main(["calibrate", *views[:4], *BOARD, "--distortion", "k9", "-q"]) == 2
    assert "argument --distortion: invalid choice" in _one_error(capsys)


def test_parallel_views_and_a_small_pattern_are_warned_about(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    shifts = [(-0.05, -0.03), (0.05, 0.03), (0.0, 0.0), (0.05, -0.03), (-0.05, 0.03)]
    parallel = [make_transform(np.eye(3), np.array([x, y, 0.4]) - CENTRE) for x, y in shifts]
    files = _write(tmp_path / "parallel", parallel)
    assert main(["calibrate", *files, *BOARD, "--out", str(tmp_path / "p.yaml"), "-q"]) == 0
    err = capsys.readouterr().err
    assert "warning: the views are tilted by at most 0.5 deg from one another" in err
    far = []
    for rv in ([0.4, 0, 0], [0, 0.4, 0], [-0.4, 0.2, 0], [0.2, -0.4, 0.1]):
        R = make_transform(rotvec=rv)[:3, :3]
        far.append(make_transform(R, np.array([0.0, 0.0, 0.8]) - R @ CENTRE))
    files = _write(tmp_path / "far", far)
    assert main(["calibrate", *files, *BOARD, "--out", str(tmp_path / "f.yaml"), "-q"]) == 0
    err = capsys.readouterr().err
    assert "warning: the pattern covers 5% of the image over all views (less than 25%)" in err


def test_too_small_and_too_large_images_are_refused(
    views: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)  # the default --out camera.yaml is never written here
    tiny = tmp_path / "tiny.png"
    cv2.imwrite(str(tiny), np.zeros((1, 1), np.uint8))
    assert main(["calibrate", *views[:3], str(tiny), *BOARD, "-q"]) == 2
    assert f"{tiny}: the image is 1 x 1 pixels; a calibration image needs at least 32" in (
        _one_error(capsys)
    )
    huge = _png_header_only(tmp_path / "huge.png", 20000, 20000)  # refused from its header
    assert main(["calibrate", *views[:3], str(huge), *BOARD, "-q"]) == 2
    assert f"{huge}: the image is 20000 x 20000 pixels (400 megapixels)" in _one_error(capsys)
    with pytest.raises(Exception, match="megapixels"):
        calibrate_camera([np.zeros((8000, 8000), np.uint8)])


@pytest.mark.parametrize("option", ["--out", "--poses-out"])
def test_an_unwritable_output_is_refused_before_the_work(
    views: list[str], tmp_path: Path, option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("a file, not a folder")
    target = blocker / "cam.yaml"
    assert main(["calibrate", *views[:3], *BOARD, option, str(target)]) == 2
    err = _one_error(capsys)  # no "detecting ..." progress line: nothing was read
    assert f"{option} {target}: cannot write there" in err


# -- calibrate-hand-eye --------------------------------------------------------------------------


def _pose_file(tmp_path: Path, pairs: object) -> Path:
    import json

    path = tmp_path / "poses.json"
    path.write_text(json.dumps(pairs))
    return path


GOOD_POSE = {"translation": [0.1, 0.0, 0.5], "rotvec": [0.0, 0.1, 0.0]}


@pytest.mark.parametrize(
    ("wMe", "message"),
    [
        ({"translation": [0, 0, 0], "rotvec": "abc"}, "pairs[0].wMe.rotvec: expected 3 numbers"),
        ({"translation": ["0", 0, 0]}, "pairs[0].wMe.translation: expected 3 numbers (m)"),
        ({"translation": [True, 0, 0]}, "pairs[0].wMe.translation: expected 3 numbers (m)"),
        ({"translation": [1e308, 0, 0]}, "pairs[0].wMe.translation: must be finite and at most"),
        ({"rotvec": [0, 0, 1e3]}, "pairs[0].wMe.rotvec: must be finite and at most 12.57 rad"),
        (
            [[1, 0, 0, 1e308], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
            "pairs[0].wMe: the translation [1e+308, 0, 0] m is longer than 100 m",
        ),
        ([[1, 0, 0], "x"], "pairs[0].wMe: expected a 4x4 list of numbers"),
    ],
)
def test_hand_eye_pose_values_are_validated(
    tmp_path: Path, wMe: object, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _pose_file(tmp_path, [{"wMe": wMe, "cMo": GOOD_POSE}] * 3)
    assert main(["calibrate-hand-eye", str(path)]) == 2
    err = _one_error(capsys)
    assert f"{path}: {message}" in err, err


def test_hand_eye_deep_json_and_bad_csv_numbers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    assert main(["calibrate-hand-eye", str(deep)]) == 2
    assert f"{deep}: the JSON is nested too deeply" in _one_error(capsys)
    from redservo.calibration.pose_file import CSV_COLUMNS

    for bad, message in (("inf", "must be finite"), ("1e308", "must be finite and at most 100")):
        path = tmp_path / "p.csv"
        row = ["0.1"] * 12
        row[0] = bad
        path.write_text(",".join(CSV_COLUMNS) + "\n" + (",".join(row) + "\n") * 3)
        assert main(["calibrate-hand-eye", str(path)]) == 2
        assert f"{path}: row 0 wMe translation: {message}" in _one_error(capsys)


@pytest.mark.parametrize(("recorded", "asked"), [("hand", "world"), ("world", "hand")])
def test_hand_eye_mount_mismatch_is_explained(
    tmp_path: Path, recorded: str, asked: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from tests.test_calibration import _pairs

    wMe, cMo = _pairs(recorded)
    pairs = [{"wMe": a.tolist(), "cMo": b.tolist()} for a, b in zip(wMe, cMo, strict=True)]
    path = _pose_file(tmp_path, pairs)
    assert main(["calibrate-hand-eye", str(path), "--mount", asked]) == 2
    err = _one_error(capsys)
    assert f"these pose pairs fit mount '{recorded}'" in err and f"--mount {recorded}" in err
    assert main(["calibrate-hand-eye", str(path), "--mount", recorded]) == 0
    capsys.readouterr()


def test_hand_eye_unwritable_out_is_refused_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    path = _pose_file(tmp_path, [{"wMe": GOOD_POSE, "cMo": GOOD_POSE}])  # 1 pair: would fail
    assert main(["calibrate-hand-eye", str(path), "--out", str(blocker / "he.toml")]) == 2
    assert "--out" in _one_error(capsys)
