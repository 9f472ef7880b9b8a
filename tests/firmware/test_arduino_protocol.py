"""protocol.py on its own: encoders, the resynchronising decoder, malformed input."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from facesynth.services.control.drivers.arduino import protocol as proto


def reply_frame(seq: int, name: str, *values: int) -> bytes:
    message = next(m for m in proto.MESSAGES if m.direction == "reply" and m.name == name)
    return proto.encode_frame(seq, message.code, message.struct.pack(*values))


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


def test_replies_parse_into_types() -> None:
    decoder = proto.ReplyDecoder()
    status_values = [*range(1, 13), 77, 500, 0x05]
    replies = decoder.feed(
        reply_frame(9, "ACK", 0x10, 2, 0x07)
        + reply_frame(10, "NACK", 0x11, 5)
        + reply_frame(11, "VERSION", 1, 0, 1, 0, 16, 0, 144)
        + reply_frame(12, "STATUS", *status_values)
    )
    ack, nack, version, status = replies
    assert ack == proto.Ack(9, 0x10, 2, proto.Flags(7))
    assert nack == proto.Nack(10, 0x11, proto.ErrorCode.STALE_SEQUENCE)
    assert version.channels == 16 and version.output is proto.OutputKind.PCA9685
    assert isinstance(status, proto.Status)
    assert (status.frames_ok, status.uptime_ms, status.last_seq, status.watchdog_ms) == (
        1,
        12,
        77,
        500,
    )
    assert status.flags == proto.Flags.SEQ_VALID | proto.Flags.LIMITS_SET


def test_malformed_replies_are_counted_not_raised() -> None:
    decoder = proto.ReplyDecoder()
    bad = [
        proto.encode_frame(1, 0x10, b""),  # a command code, not a reply
        proto.encode_frame(2, 0x80, b"\x10\x00"),  # ACK one byte short
        reply_frame(3, "NACK", 0x10, 99),  # unknown error code
        reply_frame(4, "VERSION", 1, 0, 1, 0, 16, 7, 144),  # unknown output kind
    ]
    assert decoder.feed(b"".join(bad) + reply_frame(5, "NACK", 0x10, 1)) == [
        proto.Nack(5, 0x10, proto.ErrorCode.UNKNOWN_COMMAND)
    ]
    assert decoder.malformed == 4
    with pytest.raises(proto.ProtocolError, match="not a reply code"):
        proto.parse_reply(proto.Frame(1, 0x01, b""))


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


def test_reply_decoder_bounds_garbage_lengths() -> None:
    """A false START with a long LEN cannot hold back replies longer than the largest reply."""
    decoder = proto.ReplyDecoder()
    ack = reply_frame(7, "ACK", 0x10, 0, 3)
    assert decoder.feed(bytes([0xA5, 100]) + ack) == [proto.Ack(7, 0x10, 0, proto.Flags(3))]


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


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600))
def test_arbitrary_bytes_never_raise(data: bytes) -> None:
    decoder = proto.ReplyDecoder()
    decoder.feed(data)
    decoder.discard_partial()
    assert decoder.frames.pending <= proto.MAX_REPLY_PAYLOAD + proto.FRAME_OVERHEAD
