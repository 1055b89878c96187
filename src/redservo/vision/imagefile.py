"""Read one image file safely: a regular file, its size checked from the header before decoding.

OpenCV's ``cv2.imread`` decodes the whole image before anything can look at its size, so a
389 KB PNG of 20000 × 20000 pixels takes 1.2 GB, and it opens whatever the path names, so a
FIFO called ``a.png`` blocks forever. :func:`read_gray` therefore

1. opens the path without blocking and refuses anything but a regular file (a FIFO, socket,
   device or folder is a :class:`ConfigurationError` naming the file);
2. reads the width and height from the file's header (:func:`header_size`: PNG, JPEG, BMP,
   TIFF/BigTIFF and PGM/PPM/PBM, recognised by their content, not their suffix) and refuses
   an image larger than :data:`MAX_IMAGE_PIXELS`, or a file whose header it cannot read;
3. only then decodes it, in grayscale (``cv2.imread(path, cv2.IMREAD_GRAYSCALE)``).
"""

from __future__ import annotations

import os
import stat
import struct
from pathlib import Path
from typing import BinaryIO

import numpy as np
from numpy.typing import NDArray

from redservo.errors import ConfigurationError
from redservo.vision.optics import require_cv2

__all__ = ["MAX_IMAGE_PIXELS", "check_frame_size", "header_size", "read_gray"]

MAX_IMAGE_PIXELS = 50_000_000
"""Largest image read from a file or a capture, in pixels (width × height): 50 megapixels,
e.g. 8660 × 5773. Decoding one costs up to 4 bytes per pixel (200 MB) before the grayscale
conversion; a dot tracker has no use for more. Checked from the header, before decoding."""

_SOF = frozenset({0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF})
"""JPEG start-of-frame markers (they hold the image size)."""


def _unpack(fmt: str, data: bytes) -> tuple[int, ...]:
    if len(data) < struct.calcsize(fmt):
        raise ValueError("truncated header")
    return struct.unpack(fmt, data)


def _jpeg(f: BinaryIO) -> tuple[int, int]:
    f.seek(2)
    while True:
        byte = f.read(1)
        if not byte:
            raise ValueError("no start-of-frame marker")
        if byte != b"\xff":
            continue  # entropy-coded data or padding between segments
        marker = f.read(1)
        while marker == b"\xff":  # fill bytes
            marker = f.read(1)
        if not marker:
            raise ValueError("no start-of-frame marker")
        m = marker[0]
        if m == 0x00 or m == 0x01 or 0xD0 <= m <= 0xD8:
            continue  # stuffed byte or a marker without a length
        if m == 0xD9:
            raise ValueError("end of image before a start-of-frame marker")
        (length,) = _unpack(">H", f.read(2))
        if m in _SOF:
            _, height, width = _unpack(">BHH", f.read(5))
            return width, height
        if length < 2:
            raise ValueError("bad segment length")
        f.seek(length - 2, os.SEEK_CUR)


def _tiff(f: BinaryIO, head: bytes) -> tuple[int, int]:
    e = "<" if head[:2] == b"II" else ">"
    (version,) = _unpack(e + "H", head[2:4])
    big = version == 43
    if big:
        f.seek(8)
        (ifd,) = _unpack(e + "Q", f.read(8))
        f.seek(ifd)
        (count,) = _unpack(e + "Q", f.read(8))
        entry, value_at = 20, 12
    else:
        (ifd,) = _unpack(e + "I", head[4:8])
        f.seek(ifd)
        (count,) = _unpack(e + "H", f.read(2))
        entry, value_at = 12, 8
    size: dict[int, int] = {}
    for _ in range(min(count, 4096)):
        raw = f.read(entry)
        tag, kind = _unpack(e + "HH", raw[:4])
        if tag in (256, 257):  # ImageWidth, ImageLength: SHORT (3), LONG (4) or LONG8 (16)
            code = {3: "H", 4: "I", 16: "Q"}.get(kind)
            if code is None:
                raise ValueError(f"TIFF tag {tag} of type {kind}")
            (size[tag],) = _unpack(e + code, raw[value_at : value_at + struct.calcsize(code)])
        if len(size) == 2:
            return size[256], size[257]
    raise ValueError("no ImageWidth/ImageLength tag")


def _pnm(f: BinaryIO) -> tuple[int, int]:
    f.seek(2)
    values: list[int] = []
    token = b""
    for _ in range(4096):  # the header is short; comments are skipped
        c = f.read(1)
        if c == b"#":
            while c not in (b"\n", b"\r", b""):
                c = f.read(1)
        if c.isdigit():
            token += c
            continue
        if token:
            values.append(int(token))
            token = b""
            if len(values) == 2:
                return values[0], values[1]
        if not c:
            break
        if not c.isspace():
            raise ValueError("bad PNM header")
    raise ValueError("no width and height in the PNM header")


def header_size(f: BinaryIO) -> tuple[int, int]:
    """``(width, height)`` in pixels of the image in ``f``, from its header (nothing decoded).

    Raises:
        ValueError: not a PNG, JPEG, BMP, TIFF or PNM file, or a truncated header.
    """
    head = f.read(32)
    if head[:8] == b"\x89PNG\r\n\x1a\n":
        if head[12:16] != b"IHDR":
            raise ValueError("PNG without an IHDR chunk")
        w, h = _unpack(">II", head[16:24])
        return w, h
    if head[:2] == b"\xff\xd8":
        return _jpeg(f)
    if head[:2] == b"BM":
        (dib,) = _unpack("<I", head[14:18])
        if dib == 12:  # OS/2 BITMAPCOREHEADER
            w, h = _unpack("<HH", head[18:22])
            return w, h
        w, h = _unpack("<ii", head[18:26])
        return abs(w), abs(h)  # a negative height is a top-down bitmap
    if head[:4] in (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"):
        return _tiff(f, head)
    if head[:1] == b"P" and head[1:2] in (b"1", b"2", b"3", b"4", b"5", b"6"):
        return _pnm(f)
    raise ValueError("not a PNG, JPEG, BMP, TIFF or PGM/PPM file")


def check_frame_size(width: int, height: int, what: str) -> None:
    """Raise :class:`ConfigurationError` naming ``what`` when the frame exceeds the cap."""
    if width * height > MAX_IMAGE_PIXELS:
        raise ConfigurationError(
            f"{what}: the image is {width} x {height} pixels ({width * height / 1e6:.0f} "
            f"megapixels), more than the {MAX_IMAGE_PIXELS / 1e6:.0f} megapixels allowed "
            "(redservo.vision.imagefile.MAX_IMAGE_PIXELS); scale it down first"
        )


def read_gray(path: str | Path) -> NDArray[np.uint8]:
    """The image file ``path`` as a (H, W) ``uint8`` grayscale array (module docstring).

    Raises:
        ConfigurationError: not a regular file, cannot be opened, an unknown or truncated
            header, larger than :data:`MAX_IMAGE_PIXELS`, or not decodable; the message
            names the file.
    """
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise ConfigurationError(f"{p}: cannot open the image ({exc.strerror})") from None
    with os.fdopen(fd, "rb") as f:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise ConfigurationError(
                f"{p}: not a regular file (a FIFO, socket, device or folder); an image folder "
                "may hold only regular image files"
            )
        try:
            width, height = header_size(f)
        except (ValueError, OSError, struct.error) as exc:
            raise ConfigurationError(f"{p}: not a readable image ({exc})") from None
    check_frame_size(width, height, str(p))
    img = require_cv2().imread(str(p), require_cv2().IMREAD_GRAYSCALE)
    if img is None:
        raise ConfigurationError(f"{p}: not a readable image (OpenCV cannot decode it)")
    return np.ascontiguousarray(img)
