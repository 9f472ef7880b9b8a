"""Fuzz the MJPEG passthrough's parsers: the ``multipart/x-mixed-replace`` parser
(:mod:`facesynth.services.sensor.sources.multipart`) and a part's JPEG check
(:func:`facesynth.services.sensor.sources.mjpeg.part_image`).

Streams are built from well-formed parts (with and without Content-Length, before a closing
boundary or not) mixed with broken pieces (another boundary, a header line without a name, a
Content-Length that is not a number or too large, random bytes), or a well-formed stream
damaged; each is fed in random chunk sizes. Every case gives parts or a
:class:`MultipartError`; parts are never larger than the limit; a stream of well-formed parts
gives back exactly their bodies however it is cut; every part is a :class:`JpegImage` (whose
size is the JPEG header's) or a :class:`JpegHeaderError`.
"""

from __future__ import annotations

import numpy as np
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged

from facesynth.runtime.jpeg import JpegHeaderError, jpeg_size
from facesynth.runtime.opencv import import_cv2
from facesynth.services.sensor.sources.mjpeg import part_image
from facesynth.services.sensor.sources.multipart import MultipartError, MultipartParser, Part

pytestmark = [pytest.mark.fuzz, TIMEOUT]

cv2 = import_cv2(RuntimeError)
JPEG = bytes(cv2.imencode(".jpg", np.full((8, 16, 3), 90, np.uint8))[1].tobytes())
MAX_PART = 4096


def framed(body: bytes, length: bool) -> bytes:
    head = b"--frame\r\nContent-Type: image/jpeg\r\n"
    if length:
        head += b"Content-Length: %d\r\n" % len(body)
    return head + b"\r\n" + body + b"\r\n"


#: A part's bytes: the JPEG, the JPEG cut short (cheap to draw; damage comes with the stream
#: kind "damaged"), or any bytes.
bodies = st.one_of(
    st.just(JPEG), st.integers(0, len(JPEG)).map(lambda n: JPEG[:n]), st.binary(max_size=300)
)
good_parts = st.tuples(bodies, st.booleans())
broken_pieces = st.sampled_from(
    [
        b"--other\r\n\r\n",
        b"--frame\r\nno colon here\r\n\r\n",
        b"--frame\r\nContent-Length: 12x\r\n\r\n",
        b"--frame\r\nContent-Length: 99999999\r\n\r\n",
        b"--frame--\r\n",
        b"\r\n",
        b"--frame\n: empty name\n\n",
    ]
)


# What a stream draws from, built once (not again inside every draw).
_KINDS = st.sampled_from(["valid", "broken", "damaged", "random"])
_RANDOM = st.binary(max_size=600)
_BROKEN = st.lists(st.one_of(good_parts.map(lambda p: framed(*p)), broken_pieces))
_PARTS = st.lists(good_parts, max_size=4)


@st.composite
def streams(draw: st.DrawFn) -> tuple[bytes, list[bytes] | None]:
    """A stream, and the bodies it must give when it is well-formed (else None)."""
    kind = draw(_KINDS)
    if kind == "random":
        return draw(_RANDOM), None
    if kind == "broken":
        pieces = draw(_BROKEN)
        return b"".join(pieces), None
    parts = draw(_PARTS)
    # A part without a length ends at the next boundary line: the final one completes it.
    stream = b"".join(framed(body, length) for body, length in parts) + b"--frame\r\n"
    if kind == "valid":
        # A body without a length holding a boundary line of its own is cut there.
        cut = any(not length and b"\n--frame" in body for body, length in parts)
        return stream, None if cut else [body for body, _ in parts]
    return draw(damaged(stream)), None


def parse(stream: bytes, cuts: list[int]) -> list[Part]:
    parser = MultipartParser("frame", max_part=MAX_PART, max_header=512)
    parts: list[Part] = []
    at = 0
    for cut in [*cuts, len(stream)]:
        parts += parser.feed(stream[at : at + cut] if cut < len(stream) else stream[at:])
        at += cut
        if at >= len(stream):
            break
    return parts


def test_multipart_streams_give_parts_or_a_multipart_error() -> None:
    target = "sensor.multipart"
    jpegs = "sensor.mjpeg.part_image"

    @FUZZ
    @given(streams(), st.lists(st.integers(1, 400), max_size=8))
    def case(stream_and_expected: tuple[bytes, list[bytes] | None], cuts: list[int]) -> None:
        stream, expected = stream_and_expected
        parts = outcome(target, lambda: parse(stream, cuts), MultipartError)
        if expected is not None:
            assert parts is not None and [p.body for p in parts] == expected
        for part in parts or []:
            assert len(part.body) <= MAX_PART
            image = outcome(jpegs, lambda body=part.body: part_image(body), JpegHeaderError)
            if image is not None:
                assert (image.width, image.height) == jpeg_size(image.data)
                assert image.data.endswith(b"\xff\xd9")

    case()
    check_tally(target, "valid", "refused")
    check_tally(jpegs, "valid", "refused", every_case=False)
