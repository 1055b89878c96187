"""``python -m redservo.vision``: bad options, huge images, FIFOs and unwritable outputs are one
line on stderr with exit code 2, as for ``redservo``; the image size is read from the header,
before anything is decoded."""

from __future__ import annotations

import io
import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

from redservo.errors import ConfigurationError

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.vision import imagefile  # noqa: E402
from redservo.vision.__main__ import PROG, main  # noqa: E402
from redservo.vision.imagefile import MAX_IMAGE_PIXELS, header_size, read_gray  # noqa: E402
from redservo.vision.sources import frames, track_dots  # noqa: E402


def _png_header_only(path: Path, width: int, height: int) -> Path:
    """A small PNG file whose header claims ``width`` × ``height`` (its data is a stub)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(b"\0" * 100))
        + chunk(b"IEND", b"")
    )
    return path


def _dots_folder(folder: Path, n: int = 3) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    img = np.zeros((480, 640), np.uint8)
    cv2.circle(img, (100, 100), 5, 255, -1)
    cv2.circle(img, (300, 200), 5, 255, -1)
    for k in range(n):
        cv2.imwrite(str(folder / f"{k:03d}.png"), img)
    return folder


def _one_error_line(err: str) -> str:
    assert "Traceback" not in err, err
    assert err.endswith("\n") and err.count("\n") == 1, err
    assert err.startswith(f"{PROG}: error: "), err
    return err


BAD_OPTIONS = [
    (["--threshold", "abc"], "argument --threshold"),
    (["--threshold", "nan"], "argument --threshold"),
    (["--threshold", "300"], "argument --threshold"),
    (["--px", "0"], "argument --px: must be positive"),
    (["--px", "nan"], "argument --px: must be finite"),
    (["--py", "-1"], "argument --py: must be positive"),
    (["--u0", "inf"], "argument --u0: must be finite"),
    (["--k1", "2"], "argument --k1"),
    (["--dots", "-3"], "argument --dots: must be in [1,"),
    (["--dots", "0"], "argument --dots: must be in [1,"),
    (["--dots", "2.5"], "argument --dots: expected a positive integer"),
    (["--max-size", "-5"], "argument --max-size: must be at least 2"),
    (["--max-size", "1"], "argument --max-size: must be at least 2"),
    (["--frames", "-1"], "argument --frames: must be in [1,"),
    (["--frames", "0"], "argument --frames: must be in [1,"),
    (["--gif", "out.webm"], "argument --gif"),
    (["--no-such-option"], "unrecognized arguments"),
]


@pytest.mark.parametrize(
    ("extra", "expect"), BAD_OPTIONS, ids=[" ".join(a) for a, _ in BAD_OPTIONS]
)
def test_bad_options_are_one_line_and_nothing_runs(
    extra: list[str], expect: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _dots_folder(tmp_path / "shots")
    assert main([str(folder), *extra]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # rejected before any frame is read
    assert expect in _one_error_line(err)


def test_a_subprocess_gets_one_line_and_exit_code_2(tmp_path: Path) -> None:
    folder = _dots_folder(tmp_path / "shots")
    for extra in (["--threshold", "abc"], ["--px", "nan"]):
        proc = subprocess.run(
            [sys.executable, "-m", "redservo.vision", str(folder), *extra],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert proc.returncode == 2, proc
        assert proc.stdout == ""
        _one_error_line(proc.stderr)


def test_an_image_over_the_size_cap_is_refused_from_its_header(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "huge"
    folder.mkdir()
    _png_header_only(folder / "a.png", 40000, 40000)
    decoded: list[str] = []
    monkeypatch.setattr(cv2, "imread", lambda *a, **k: decoded.append(a[0]))  # must not run
    assert main([str(folder)]) == 2
    err = _one_error_line(capsys.readouterr().err)
    assert f"{folder / 'a.png'}: the image is 40000 x 40000 pixels" in err
    assert "50 megapixels" in err
    assert decoded == []
    # Just over and just at the cap.
    side = int(np.sqrt(MAX_IMAGE_PIXELS))
    with pytest.raises(ConfigurationError, match="megapixels allowed"):
        read_gray(_png_header_only(tmp_path / "over.png", side + 1, side + 1))
    assert decoded == []
    monkeypatch.undo()
    with pytest.raises(ConfigurationError, match="OpenCV cannot decode"):  # passed the check
        read_gray(_png_header_only(tmp_path / "at.png", side, side))


def test_a_real_decompression_bomb_is_refused_cheaply(tmp_path: Path) -> None:
    """A 20000² PNG of zeros is a few hundred KB; reading it used to take 1.2 GB."""
    bomb = tmp_path / "bomb.png"
    z = zlib.compressobj(9)
    block = b"\0" * (20000 + 1) * 500  # 500 rows: a filter byte and 20000 zeros each
    rows = b"".join(z.compress(block) for _ in range(40)) + z.flush()

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    ihdr = struct.pack(">IIBBBBB", 20000, 20000, 8, 0, 0, 0, 0)
    bomb.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", rows) + chunk(b"IEND", b"")
    )
    assert bomb.stat().st_size < 1_000_000
    # The child's own peak: VmHWM belongs to its address space, while getrusage's ru_maxrss
    # keeps the parent's peak across fork + exec (a 2 GB pytest made a cheap refusal look
    # expensive).
    code = (
        "from redservo.vision.__main__ import main\n"
        f"rc = main([{str(tmp_path)!r}])\n"
        "hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM:')]\n"
        "print(rc, hwm[0] if hwm else 0)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    rc, peak_kb = proc.stdout.split()
    assert rc == "2" and "20000 x 20000 pixels" in proc.stderr
    assert int(peak_kb) < 400_000, f"peak memory {int(peak_kb) / 1e3:.0f} MB"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_a_fifo_named_like_an_image_is_refused_not_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Opening a FIFO for reading blocks until a writer comes: it must never be opened."""
    folder = _dots_folder(tmp_path / "shots")
    os.mkfifo(folder / "a.png")
    proc = subprocess.run(
        [sys.executable, "-m", "redservo.vision", str(folder)],
        capture_output=True,
        text=True,
        timeout=300,  # a hang is a failure, not a stuck suite
    )
    assert proc.returncode == 2 and proc.stdout == ""  # refused before the first frame
    err = _one_error_line(proc.stderr)
    assert f"{folder / 'a.png'}: not a regular file" in err
    # The reader itself refuses it without blocking, too (O_NONBLOCK, then fstat).
    with pytest.raises(ConfigurationError, match="not a regular file"):
        read_gray(folder / "a.png")
    # A folder named like an image is refused the same way.
    os.unlink(folder / "a.png")
    (folder / "b.png").mkdir()
    with pytest.raises(ConfigurationError, match=r"b\.png: not a regular file"):
        list(frames(folder))


def test_an_unwritable_output_is_one_line_before_any_frame(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _dots_folder(tmp_path / "shots")
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    assert main([str(folder), "--gif", str(blocker / "out.gif")]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert f"{blocker} is not a folder" in _one_error_line(err)
    (tmp_path / "dir.gif").mkdir()
    assert main([str(folder), "--gif", str(tmp_path / "dir.gif")]) == 2
    assert "is a folder" in _one_error_line(capsys.readouterr().err)


def test_gif_from_a_camera_needs_frames(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["0", "--gif", "x.gif"]) == 2
    assert "needs --frames" in _one_error_line(capsys.readouterr().err)


def test_a_good_run_still_works(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _dots_folder(tmp_path / "shots")
    assert main([str(folder), "--dots", "2", "--frames", "2", "--threshold", "128"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 2 and out[0].startswith("frame 0: ")


def test_library_arguments_are_checked() -> None:
    with pytest.raises(ConfigurationError, match="n_dots must be a positive integer"):
        track_dots([np.zeros((10, 10), np.uint8)], 0)
    with pytest.raises(ConfigurationError, match="max_frames must be a positive integer"):
        list(frames([np.zeros((10, 10), np.uint8)], max_frames=-1))
    with pytest.raises(ConfigurationError, match="min_size_px <= max_size_px"):
        track_dots([np.zeros((10, 10), np.uint8)], 2, max_size_px=-5.0)


@pytest.mark.parametrize("suffix", [".png", ".jpg", ".bmp", ".tif", ".pgm", ".ppm"])
def test_header_size_matches_what_opencv_decodes(suffix: str, tmp_path: Path) -> None:
    img = np.random.default_rng(0).integers(0, 255, (37, 53), dtype=np.uint8)
    path = tmp_path / f"a{suffix}"
    data = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR) if suffix == ".ppm" else img
    assert cv2.imwrite(str(path), data)
    with path.open("rb") as f:
        assert header_size(f) == (53, 37)
    assert read_gray(path).shape == (37, 53)


def test_header_size_of_pillow_variants(tmp_path: Path) -> None:
    """Files other writers make: a progressive JPEG with a large EXIF segment, a TIFF, a BMP,
    an RGBA PNG; then hand-made headers (big-endian TIFF, PGM with a comment) and junk."""
    Image = pytest.importorskip("PIL.Image")
    rgb = Image.fromarray(np.zeros((21, 34, 3), np.uint8))
    cases = {
        "prog.jpg": {"progressive": True, "exif": b"Exif\x00\x00" + b"\x00" * 4000},
        "a.tif": {},
        "a.bmp": {},
        "rgba.png": {},
    }
    for name, kw in cases.items():
        path = tmp_path / name
        (rgb.convert("RGBA") if name == "rgba.png" else rgb).save(path, **kw)
        with path.open("rb") as f:
            assert header_size(f) == (34, 21), name
    # Hand-made headers: a big-endian TIFF and a PGM with a comment.
    ifd = struct.pack(">H", 2) + struct.pack(">HHII", 256, 4, 1, 34)
    ifd += struct.pack(">HHIHH", 257, 3, 1, 21, 0) + b"\0\0\0\0"
    assert header_size(io.BytesIO(b"MM\x00*" + struct.pack(">I", 8) + ifd)) == (34, 21)
    assert header_size(io.BytesIO(b"P5\n# made by hand\n34 21\n255\n" + b"\0" * 714)) == (34, 21)
    for junk in (b"", b"GIF89a....", b"\x89PNG\r\n\x1a\n\0\0", b"\xff\xd8\xff\xd9"):
        with pytest.raises(ValueError):
            header_size(io.BytesIO(junk))


def test_a_file_with_an_unknown_header_names_the_file(tmp_path: Path) -> None:
    (tmp_path / "a.png").write_bytes(b"GIF89a not what the name says")
    with pytest.raises(ConfigurationError, match=r"a\.png: not a readable image"):
        list(frames(tmp_path))


def test_the_cap_is_documented() -> None:
    assert imagefile.MAX_IMAGE_PIXELS == 50_000_000
    text = (Path(__file__).parents[1] / "docs" / "vision.md").read_text()
    assert "50 megapixels" in text and "MAX_IMAGE_PIXELS" in text
