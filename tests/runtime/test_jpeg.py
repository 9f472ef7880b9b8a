"""runtime.jpeg: a JPEG's size from its header, never by decoding it; damaged headers refused."""

from __future__ import annotations

import struct
import time

import cv2
import numpy as np
import pytest

from facesynth.runtime.jpeg import JpegHeaderError, jpeg_size


def _jpeg(width: int, height: int, **params: int) -> bytes:
    flags = [item for pair in params.items() for item in (getattr(cv2, pair[0]), pair[1])]
    ok, buffer = cv2.imencode(".jpg", np.zeros((height, width, 3), np.uint8), flags)
    assert ok
    return buffer.tobytes()


def _sof(width: int, height: int, marker: int = 0xC0, pad: bytes = b"") -> bytes:
    """A hand-made header: SOI, an APP segment, fill bytes, then a frame header."""
    app = b"\xff\xe0" + struct.pack(">H", 2 + len(pad)) + pad
    sof = bytes([0xFF, 0xFF, 0xFF, marker]) + struct.pack(">HBHHB", 11, 8, height, width, 1)
    return b"\xff\xd8" + app + sof + b"\x01\x11\x00" + b"\xff\xda\x00\x02" + b"\x00" * 8


@pytest.mark.parametrize(("width", "height"), [(1, 1), (16, 9), (640, 480), (1920, 1080)])
@pytest.mark.parametrize("progressive", [0, 1], ids=["baseline", "progressive"])
def test_real_jpegs_give_their_size(width: int, height: int, progressive: int) -> None:
    data = _jpeg(width, height, IMWRITE_JPEG_PROGRESSIVE=progressive)
    assert jpeg_size(data) == (width, height)


@pytest.mark.parametrize("marker", [0xC0, 0xC1, 0xC2, 0xC3, 0xC9, 0xCF])
def test_every_frame_header_kind_is_read(marker: int) -> None:
    assert jpeg_size(_sof(16000, 12000, marker, pad=b"x" * 300)) == (16000, 12000)


def test_a_16000_pixel_claim_is_read_in_microseconds() -> None:
    data = _sof(16000, 16000) + b"\x00" * 4_000_000  # a 4 MB JPEG declaring 16000x16000
    start = time.perf_counter()
    for _ in range(100):
        assert jpeg_size(data) == (16000, 16000)
    assert (time.perf_counter() - start) / 100 < 0.001


@pytest.mark.parametrize(
    ("data", "detail"),
    [
        (b"", "not a JPEG"),
        (b"\x89PNG\r\n\x1a\n", "not a JPEG"),
        (b"\xff\xd8", "not a JPEG"),
        (b"\xff\xd8\xff\xe0\x00", "cut short"),
        (b"\xff\xd8\xff\xe0\x00\x10abc", "cut short"),
        (b"\xff\xd8\x00\x00\x00\x00", "no JPEG marker at byte 2"),
        (b"\xff\xd8\xff\xe0\x00\x01", "has a length of 1"),
        (b"\xff\xd8\xff\xda\x00\x08" + b"\x00" * 8, "no frame header before marker 0xFFDA"),
        (b"\xff\xd8\xff\xd9", "no frame header before marker 0xFFD9"),
        (b"\xff\xd8\xff\xd8\xff\xd8", "no frame header before marker 0xFFD8"),
        (b"\xff\xd8\xff\xc0\x00\x0b\x08\x00", "cut short"),
        (_sof(640, 0), "declares 640x0 pixels"),
        (_sof(0, 480), "declares 0x480 pixels"),
        (b"\xff\xd8" + b"\xff" * 1000, "cut short"),
    ],
    ids=[
        "empty",
        "png",
        "only-soi",
        "length-cut",
        "segment-cut",
        "no-marker",
        "length-one",
        "scan-first",
        "end-first",
        "soi-again",
        "sof-cut",
        "dnl-height",
        "zero-width",
        "fill-only",
    ],
)
def test_damaged_headers_are_refused(data: bytes, detail: str) -> None:
    with pytest.raises(JpegHeaderError, match=detail):
        jpeg_size(data)
