"""replies.py: the firmware's replies typed (ACK, NACK, VERSION, STATUS), malformed ones counted."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.control.drivers.arduino import replies


def reply_frame(seq: int, name: str, *values: int) -> bytes:
    message = next(m for m in proto.MESSAGES if m.direction == "reply" and m.name == name)
    return proto.encode_frame(seq, message.code, message.struct.pack(*values))


def test_replies_parse_into_types() -> None:
    decoder = replies.ReplyDecoder()
    status_values = [*range(1, 13), 77, 500, 0x05]
    got = decoder.feed(
        reply_frame(9, "ACK", 0x10, 2, 0x07)
        + reply_frame(10, "NACK", 0x11, 5)
        + reply_frame(11, "VERSION", 1, 0, 1, 0, 16, 0, 144)
        + reply_frame(12, "STATUS", *status_values)
    )
    ack, nack, version, status = got
    assert ack == replies.Ack(9, 0x10, 2, proto.Flags(7))
    assert nack == replies.Nack(10, 0x11, proto.ErrorCode.STALE_SEQUENCE)
    assert version.channels == 16 and version.output is proto.OutputKind.PCA9685
    assert isinstance(status, replies.Status)
    assert (status.frames_ok, status.uptime_ms, status.last_seq, status.watchdog_ms) == (
        1,
        12,
        77,
        500,
    )
    assert status.flags == proto.Flags.SEQ_VALID | proto.Flags.LIMITS_SET


def test_malformed_replies_are_counted_not_raised() -> None:
    decoder = replies.ReplyDecoder()
    bad = [
        proto.encode_frame(1, 0x10, b""),  # a command code, not a reply
        proto.encode_frame(2, 0x80, b"\x10\x00"),  # ACK one byte short
        reply_frame(3, "NACK", 0x10, 99),  # unknown error code
        reply_frame(4, "VERSION", 1, 0, 1, 0, 16, 7, 144),  # unknown output kind
    ]
    assert decoder.feed(b"".join(bad) + reply_frame(5, "NACK", 0x10, 1)) == [
        replies.Nack(5, 0x10, proto.ErrorCode.UNKNOWN_COMMAND)
    ]
    assert decoder.malformed == 4
    with pytest.raises(proto.ProtocolError, match="not a reply code"):
        replies.parse_reply(proto.Frame(1, 0x01, b""))


def test_reply_decoder_bounds_garbage_lengths() -> None:
    """A false START with a long LEN cannot hold back replies longer than the largest reply."""
    decoder = replies.ReplyDecoder()
    ack = reply_frame(7, "ACK", 0x10, 0, 3)
    assert decoder.feed(bytes([0xA5, 100]) + ack) == [replies.Ack(7, 0x10, 0, proto.Flags(3))]


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600))
def test_arbitrary_bytes_never_raise(data: bytes) -> None:
    decoder = replies.ReplyDecoder()
    decoder.feed(data)
    decoder.discard_partial()
    assert decoder.frames.pending <= proto.MAX_REPLY_PAYLOAD + proto.FRAME_OVERHEAD
