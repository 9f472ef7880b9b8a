"""The multipart/x-mixed-replace parser: parts however the stream is cut, the boundary from
the Content-Type, and one clear error for each way a stream is malformed."""

from __future__ import annotations

import pytest

from facesynth.services.sensor.sources.multipart import MultipartError, MultipartParser, boundary_of

BODIES = [b"\xff\xd8first\xff\xd9", b"", b"\xff\xd8--frame inside\r\n\xff\xd9"]


def stream(*, length: bool = True, newline: bytes = b"\r\n") -> bytes:
    out = b""
    for body in BODIES:
        out += b"--frame" + newline + b"Content-Type: image/jpeg" + newline
        if length:
            out += b"Content-Length: %d" % len(body) + newline
        out += newline + body + newline
    return out + b"--frame--" + newline


@pytest.mark.parametrize("length", [True, False])
@pytest.mark.parametrize("newline", [b"\r\n", b"\n"])
@pytest.mark.parametrize("chunk", [1, 7, 10_000])
def test_parts_however_the_stream_is_cut(length: bool, newline: bytes, chunk: int) -> None:
    data = stream(length=length, newline=newline)
    parser = MultipartParser("frame")
    parts = []
    for at in range(0, len(data), chunk):
        parts += parser.feed(data[at : at + chunk])
    assert [p.body for p in parts] == BODIES
    assert parts[0].headers["content-type"] == "image/jpeg"
    assert parser.ended and parser.feed(b"more") == []


def test_a_boundary_given_with_its_dashes() -> None:
    assert [p.body for p in MultipartParser("--frame").feed(stream())] == BODIES


@pytest.mark.parametrize(
    ("content_type", "boundary"),
    [
        ("multipart/x-mixed-replace; boundary=frame", "frame"),
        ('Multipart/X-Mixed-Replace;boundary="--myboundary"', "--myboundary"),
        ("multipart/x-mixed-replace; charset=x; Boundary=b1", "b1"),
    ],
)
def test_the_boundary_of_a_content_type(content_type: str, boundary: str) -> None:
    assert boundary_of(content_type) == boundary


@pytest.mark.parametrize(
    ("content_type", "message"),
    [
        ("image/jpeg", "content type 'image/jpeg' is not multipart"),
        ("", "content type '\\(none\\)' is not multipart"),
        ("multipart/x-mixed-replace", "names no usable boundary"),
        ("multipart/x-mixed-replace; boundary=", "names no usable boundary"),
        ("multipart/x-mixed-replace; boundary=a\tb", "names no usable boundary"),
    ],
)
def test_content_types_without_a_boundary(content_type: str, message: str) -> None:
    with pytest.raises(MultipartError, match=message):
        boundary_of(content_type)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"--other\r\n", "expected the boundary '--frame', got '--other'"),
        (b"--frame\r\nno colon\r\n", "a part header line without a name: 'no colon'"),
        (b"--frame\r\n: value\r\n", "a part header line without a name"),
        (b"--frame\r\nContent-Length: -5\r\n\r\n", "Content-Length '-5' is not a number"),
        (b"--frame\r\nContent-Length: 999\r\n\r\n", "a part of 999 bytes \\(at most 100\\)"),
        (b"--frame\r\n\r\n" + b"x" * 101, "a part longer than 100 bytes"),
        (b"x" * 70, "no boundary line in 70 bytes"),
        (b"--frame\r\n" + b"X" * 70, "a part header line longer than 64 bytes"),
        (
            b"--frame\r\n" + b"".join(b"X%d: 123456789\r\n" % i for i in range(8)),
            "part headers longer than 64 bytes",
        ),
    ],
)
def test_malformed_streams(data: bytes, message: str) -> None:
    parser = MultipartParser("frame", max_part=100, max_header=64)
    with pytest.raises(MultipartError, match=message):
        parser.feed(data)


def test_a_stream_cut_short_waits_for_more() -> None:
    parser = MultipartParser("frame")
    assert parser.feed(b"--frame\r\nContent-Length: 10\r\n\r\n12345") == []
    assert [p.body for p in parser.feed(b"67890\r\n")] == [b"1234567890"]
