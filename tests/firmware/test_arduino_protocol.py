"""protocol.py on its own: encoders, the resynchronising frame decoder, malformed input."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from facesynth.services.control.drivers.arduino import protocol as proto


def test_crc_check_value() -> None:
    assert proto.crc16(b"123456789") == 0x29B1
    assert proto.crc16(b"") == 0xFFFF


def test_frame_layout() -> None:
    frame = proto.set_watchdog(0x1234, 1500)
    assert frame[:7] == bytes([0xA5, 2, 0x34, 0x12, 0x21, 0xDC, 0x05])
    assert struct.unpack("<H", frame[7:])[0] == proto.crc16(frame[1:7])
    assert len(proto.set_all(1, [1500] * 16)) == 39  # the 16-servo frame


def test_every_command_encodes_and_decodes() -> None:
    frames = {
        "PING": proto.ping(1),
        "STATUS": proto.status(2),
        "SET_ALL": proto.set_all(3, range(1000, 1016)),
        "SET_SOME": proto.set_some(4, {0: 1100, 15: 1900}),
        "NEUTRAL": proto.neutral(5),
        "SET_LIMITS": proto.set_limits(6, {2: proto.Limits(900, 1400, 2100, 15)}),
        "SET_WATCHDOG": proto.set_watchdog(7, 250),
    }
    assert set(frames) == set(proto.COMMANDS)
    decoded = proto.FrameDecoder().feed(b"".join(frames.values()))
    assert [(f.seq, f.code) for f in decoded] == [
        (i + 1, proto.COMMANDS[name].code) for i, name in enumerate(frames)
    ]
    by_name = dict(zip(frames, decoded, strict=True))
    assert struct.unpack("<16H", by_name["SET_ALL"].payload) == tuple(range(1000, 1016))
    assert by_name["SET_SOME"].payload == struct.pack("<BHBH", 0, 1100, 15, 1900)
    assert by_name["SET_LIMITS"].payload == struct.pack("<BHHHH", 2, 900, 1400, 2100, 15)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: proto.ping(-1), "sequence number"),
        (lambda: proto.ping(65536), "sequence number"),
        (lambda: proto.set_all(1, []), "1..16 entries"),
        (lambda: proto.set_all(1, [1500] * 17), "1..16 entries"),
        (lambda: proto.set_all(1, [70000] * 16), "does not fit"),
        (lambda: proto.set_all(1, [-1] * 16), "does not fit"),
        (lambda: proto.set_some(1, {256: 1500}), "does not fit"),
        (lambda: proto.set_watchdog(1, 65536), "does not fit"),
        (lambda: proto.encode("JUMP", 1), "unknown command"),
        (lambda: proto.encode("PING", 1, [(1,)]), "no payload"),
        (lambda: proto.encode_frame(1, 300), "message code"),
        (lambda: proto.encode_frame(1, 1, bytes(145)), "exceeds 144"),
    ],
)
def test_encoders_refuse_what_cannot_be_sent(make: object, message: str) -> None:
    with pytest.raises(proto.ProtocolError, match=message):
        make()  # type: ignore[operator]


def test_limits_problems() -> None:
    assert proto.Limits(1000, 1500, 2000).problems() == []
    assert proto.Limits(500, 500, 2500, 65535).problems() == []
    for bad in [(499, 1500, 2000), (1000, 1500, 2501), (1600, 1500, 2000), (1000, 2100, 2000)]:
        assert proto.Limits(*bad).problems()
    assert proto.Limits(1000, 1500, 2000, -1).problems()


def test_decoder_resyncs_after_bad_crc_bad_length_and_garbage() -> None:
    good = proto.ping(42)
    for i in range(len(good)):
        for bit in range(8):
            broken = bytearray(good)
            broken[i] ^= 1 << bit
            decoder = proto.FrameDecoder()
            frames = decoder.feed(bytes(broken) + good)
            frames += decoder.discard_partial()
            assert [f.seq for f in frames] == [42], (i, bit)
    decoder = proto.FrameDecoder()
    stream = b"\xa5\xff" + b"noise" + b"\xa5" * 5 + good + b"\xa5\x91" + good
    assert [f.seq for f in decoder.feed(stream)] == [42, 42]
    assert decoder.bad_length >= 6 and decoder.dropped_bytes >= 5


def test_truncated_frame_then_line_idle() -> None:
    decoder = proto.FrameDecoder()
    frame = proto.set_all(3, [1500] * 16)
    assert decoder.feed(frame[:20]) == []
    assert decoder.pending == 20
    assert decoder.discard_partial() == []
    assert decoder.pending == 0
    assert [f.seq for f in decoder.feed(frame)] == [3]


frames_strategy = st.lists(
    st.builds(
        proto.encode_frame,
        st.integers(0, 0xFFFF),
        st.integers(0, 0xFF),
        st.binary(max_size=proto.MAX_PAYLOAD),
    ),
    max_size=8,
)
garbage_without_start = st.binary(max_size=40).map(lambda b: b.replace(b"\xa5", b""))


@settings(max_examples=200, deadline=None)
@given(frames_strategy, st.lists(garbage_without_start, min_size=9, max_size=9))
def test_frames_survive_garbage_between_them(frames: list[bytes], garbage: list[bytes]) -> None:
    stream = b"".join(g + f for g, f in zip(garbage, frames, strict=False)) + garbage[-1]
    decoded = proto.FrameDecoder().feed(stream)
    assert [proto.encode_frame(f.seq, f.code, f.payload) for f in decoded] == frames


@settings(max_examples=200, deadline=None)
@given(frames_strategy, st.data())
def test_chunking_does_not_matter(frames: list[bytes], data: st.DataObject) -> None:
    stream = b"".join(frames)
    decoder = proto.FrameDecoder()
    out: list[proto.Frame] = []
    i = 0
    while i < len(stream):
        n = data.draw(st.integers(1, 50))
        out += decoder.feed(stream[i : i + n])
        i += n
    assert out == proto.FrameDecoder().feed(stream)
    assert len(out) == len(frames)
