"""The facesynth servo firmware's replies, typed: ACK, NACK, VERSION and STATUS.

:func:`parse_reply` reads one CRC-checked frame by the protocol table's reply rows;
:class:`ReplyDecoder` turns the bytes a board sends into typed replies, counting malformed ones
instead of raising. Standard library and the protocol module (table, frames) only.
"""

from __future__ import annotations

from dataclasses import dataclass

from facesynth.services.control.drivers.arduino.protocol import (
    MAX_REPLY_PAYLOAD,
    REPLIES,
    ErrorCode,
    Flags,
    Frame,
    FrameDecoder,
    OutputKind,
    ProtocolError,
)


@dataclass(frozen=True)
class Ack:
    """The command was applied; ``clamped`` positions were held to their limits."""

    seq: int
    cmd: int
    clamped: int
    flags: Flags


@dataclass(frozen=True)
class Nack:
    """The command was refused and changed nothing."""

    seq: int
    cmd: int
    error: ErrorCode


@dataclass(frozen=True)
class Version:
    """Answer to PING."""

    seq: int
    protocol: int
    major: int
    minor: int
    patch: int
    channels: int
    output: OutputKind
    max_payload: int


@dataclass(frozen=True)
class Status:
    """Answer to STATUS: counters since boot."""

    seq: int
    frames_ok: int
    crc_errors: int
    bad_length: int
    truncated: int
    unknown_command: int
    bad_value: int
    stale_sequence: int
    dropped_bytes: int
    watchdog_trips: int
    clamped: int
    output_errors: int
    uptime_ms: int
    last_seq: int
    watchdog_ms: int
    flags: Flags


Reply = Ack | Nack | Version | Status
_REPLY_TYPES: dict[str, type[Reply]] = {
    "ACK": Ack,
    "NACK": Nack,
    "VERSION": Version,
    "STATUS": Status,
}
_TYPED = {"flags": Flags, "error": ErrorCode, "output": OutputKind}


def parse_reply(frame: Frame) -> Reply:
    """The typed reply in a frame; :class:`ProtocolError` if it is not a well-formed reply."""
    message = REPLIES.get(frame.code)
    if message is None:
        raise ProtocolError(f"0x{frame.code:02x} is not a reply code")
    if len(frame.payload) != message.size:
        raise ProtocolError(
            f"{message.name} needs {message.size} payload bytes, got {len(frame.payload)}"
        )
    values = dict(
        zip((f.name for f in message.fields), message.struct.unpack(frame.payload), strict=True)
    )
    for name, kind in _TYPED.items():
        if name in values:
            try:
                values[name] = kind(values[name])
            except ValueError as exc:
                raise ProtocolError(f"{message.name}: {name} {values[name]} is unknown") from exc
    cls = _REPLY_TYPES[message.name]
    return cls(seq=frame.seq, **values)


class ReplyDecoder:
    """Bytes from the firmware in, typed replies out; malformed replies are counted, not raised."""

    def __init__(self) -> None:
        self.frames = FrameDecoder(max_payload=MAX_REPLY_PAYLOAD)
        self.malformed = 0

    def feed(self, data: bytes | bytearray | memoryview) -> list[Reply]:
        """Add received bytes; return the replies they complete."""
        return self._typed(self.frames.feed(data))

    def discard_partial(self) -> list[Reply]:
        """See :meth:`FrameDecoder.discard_partial`."""
        return self._typed(self.frames.discard_partial())

    def _typed(self, frames: list[Frame]) -> list[Reply]:
        out: list[Reply] = []
        for frame in frames:
            try:
                out.append(parse_reply(frame))
            except ProtocolError:
                self.malformed += 1
        return out
