"""Fuzz the tracker's frame decoding: ``decode_rgba`` of
:mod:`facesynth.services.points.tracker.jpeg_rgba`.

JPEGs of a few kinds (baseline 4:2:0 and 4:4:4, progressive, grey, with an EXIF block) are
damaged (cut short, bits flipped, bytes spliced in or repeated), or replaced by random bytes,
and decoded as a frame of the original's size. Every case gives exactly what OpenCV's decode
gave before (the same RGBA pixels, or a one-line :class:`FrameError`, the same text): where
libjpeg-turbo alone would decode a damaged JPEG otherwise, OpenCV still decides.
"""

from __future__ import annotations

import numpy as np
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, libjpeg_quiet, outcome
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged

from facesynth.runtime.frames import FrameError, decode_frame
from facesynth.runtime.opencv import import_cv2
from facesynth.schemas.messages import Frame
from facesynth.services.points.tracker.jpeg_rgba import decode_rgba
from facesynth.services.points.tracker.model_input import frame_to_rgba

pytestmark = [pytest.mark.fuzz, TIMEOUT]

cv2 = import_cv2(RuntimeError)
TARGET = "tracker decode_rgba (JPEG to RGBA)"
HEIGHT, WIDTH = 24, 40


def _image() -> np.ndarray:
    rng = np.random.default_rng(5)
    return cv2.resize(rng.integers(0, 256, (6, 8, 3), dtype=np.uint8), (WIDTH, HEIGHT))


def _exif(data: bytes) -> bytes:
    body = b"Exif\x00\x00II*\x00\x08\x00\x00\x00\x01\x00\x12\x01\x03\x00\x01\x00\x00\x00"
    body += b"\x06\x00\x00\x00\x00\x00\x00\x00"  # orientation 6 (a quarter turn), no next IFD
    return data[:2] + b"\xff\xe1" + (len(body) + 2).to_bytes(2, "big") + body + data[2:]


_IMAGE = _image()
JPEGS = [
    cv2.imencode(".jpg", _IMAGE, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes(),
    cv2.imencode(
        ".jpg", _IMAGE, [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444]
    )[1].tobytes(),
    cv2.imencode(".jpg", _IMAGE, [cv2.IMWRITE_JPEG_PROGRESSIVE, 1])[1].tobytes(),
    cv2.imencode(".jpg", _IMAGE[:, :, 1].copy())[1].tobytes(),
]
JPEGS.append(_exif(JPEGS[0]))

datas = st.one_of(
    st.sampled_from(JPEGS).flatmap(damaged),
    st.sampled_from(JPEGS),
    st.binary(max_size=400).map(lambda tail: b"\xff\xd8" + tail),
)


def _before(frame: Frame) -> np.ndarray | str:
    try:
        return frame_to_rgba(decode_frame(frame))
    except FrameError as exc:
        return str(exc)


@FUZZ
@given(data=datas)
def test_decode_rgba_gives_what_opencv_gave(data: bytes) -> None:
    frame = Frame(
        seq=1, t_capture_ns=0, t_media_ns=0, width=WIDTH, height=HEIGHT, encoding="jpeg", data=data
    )
    with libjpeg_quiet():
        expected = _before(frame)
        got = outcome(TARGET, lambda: decode_rgba(frame), FrameError)
        if got is None:
            with pytest.raises(FrameError) as refused:
                decode_rgba(frame)
    if isinstance(expected, str):
        assert got is None and str(refused.value) == expected
    else:
        assert got is not None and np.array_equal(got, expected)


def test_decode_rgba_cases_were_both_decoded_and_refused() -> None:
    check_tally(TARGET, "valid", "refused")
