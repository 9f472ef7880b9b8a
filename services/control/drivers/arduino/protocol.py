"""The facesynth servo firmware's serial protocol: the message table as data, frame codecs.

The replies, typed, are read by :mod:`facesynth.services.control.drivers.arduino.replies`.

Mirrors ``firmware/PROTOCOL.md`` and ``firmware/facesynth_servo/protocol.h`` (a test checks that
the three agree). Standard library only, no imports from ``facesynth``.

Frame, both directions, multi-byte fields little-endian::

    START 0xA5 | LEN u8 | SEQ u16 | CMD u8 | PAYLOAD[LEN] | CRC u16

LEN counts the payload (0..144). CRC is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no
reflection, no final xor) over LEN, SEQ, CMD and PAYLOAD. Replies echo the command's SEQ.
"""

from __future__ import annotations

import enum
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

PROTOCOL_VERSION = 1
START = 0xA5
MAX_PAYLOAD = 144
FRAME_OVERHEAD = 7
MAX_CHANNELS = 16
FRAME_TIMEOUT_MS = 50
US_ABS_MIN, US_ABS_MAX = 500, 2500
US_DEFAULT_MIN, US_DEFAULT_NEUTRAL, US_DEFAULT_MAX = 1000, 1500, 2000
WATCHDOG_DEFAULT_MS, WATCHDOG_MIN_MS, WATCHDOG_MAX_MS = 500, 20, 60000
STEP_PERIOD_MS = 20

_FORMATS = {"u8": "B", "u16": "H", "u32": "I"}


class ProtocolError(ValueError):
    """A value that cannot be encoded, or a frame that is not a valid reply."""


class ErrorCode(enum.IntEnum):
    """NACK error codes."""

    UNKNOWN_COMMAND = 1
    BAD_LENGTH = 2
    BAD_CHANNEL = 3
    BAD_VALUE = 4
    STALE_SEQUENCE = 5


class Flags(enum.IntFlag):
    """The flags byte of ACK and STATUS."""

    SEQ_VALID = 0x01
    WATCHDOG_ARMED = 0x02
    LIMITS_SET = 0x04
    OUTPUT_FAULT = 0x08


class OutputKind(enum.IntEnum):
    """What drives the servos, as reported by VERSION."""

    PCA9685 = 0
    PINS = 1


@dataclass(frozen=True)
class Field:
    """One little-endian payload field."""

    name: str
    kind: str  # "u8" | "u16" | "u32"


def _fields(spec: str) -> tuple[Field, ...]:
    return tuple(Field(*item.strip().split(":")) for item in spec.split(",") if item.strip())


@dataclass(frozen=True)
class Message:
    """A row of the protocol table.

    ``repeat`` is ``""`` for a fixed payload, ``"N"`` for exactly one entry per channel, ``"k"``
    for 1..channels entries; ``fields`` describe the payload or one entry of it.
    """

    name: str
    code: int
    direction: str  # "command" | "reply"
    fields: tuple[Field, ...]
    repeat: str
    reply: str

    @property
    def struct(self) -> struct.Struct:
        """The fixed payload, or one entry of a repeated payload."""
        return struct.Struct("<" + "".join(_FORMATS[f.kind] for f in self.fields))

    @property
    def size(self) -> int:
        """Payload size (fixed payloads) or entry size (repeated payloads), in bytes."""
        return self.struct.size

    @property
    def layout(self) -> str:
        """The payload column of PROTOCOL.md's table."""
        if not self.fields:
            return "—"
        body = ", ".join(f"{f.name}:{f.kind}" for f in self.fields)
        return f"{self.repeat} × ({body})" if self.repeat else body


def _msg(
    name: str, code: int, direction: str, spec: str, repeat: str = "", reply: str = ""
) -> Message:
    return Message(name, code, direction, _fields(spec), repeat, reply)


_STATUS_SPEC = (
    "frames_ok:u32, crc_errors:u32, bad_length:u32, truncated:u32, unknown_command:u32, "
    "bad_value:u32, stale_sequence:u32, dropped_bytes:u32, watchdog_trips:u32, clamped:u32, "
    "output_errors:u32, uptime_ms:u32, last_seq:u16, watchdog_ms:u16, flags:u8"
)

#: The protocol table: every command and reply (PROTOCOL.md has the same rows).
MESSAGES: tuple[Message, ...] = (
    _msg("PING", 0x01, "command", "", reply="VERSION"),
    _msg("STATUS", 0x02, "command", "", reply="STATUS"),
    _msg("SET_ALL", 0x10, "command", "us:u16", "N", "ACK / NACK"),
    _msg("SET_SOME", 0x11, "command", "ch:u8, us:u16", "k", "ACK / NACK"),
    _msg("NEUTRAL", 0x12, "command", "", reply="ACK / NACK"),
    _msg(
        "SET_LIMITS",
        0x20,
        "command",
        "ch:u8, min:u16, neutral:u16, max:u16, max_step:u16",
        "k",
        "ACK / NACK",
    ),
    _msg("SET_WATCHDOG", 0x21, "command", "ms:u16", reply="ACK / NACK"),
    _msg("ACK", 0x80, "reply", "cmd:u8, clamped:u8, flags:u8"),
    _msg("NACK", 0x81, "reply", "cmd:u8, error:u8"),
    _msg(
        "VERSION",
        0x82,
        "reply",
        "protocol:u8, major:u8, minor:u8, patch:u8, channels:u8, output:u8, max_payload:u8",
    ),
    _msg("STATUS", 0x83, "reply", _STATUS_SPEC),
)
COMMANDS: dict[str, Message] = {m.name: m for m in MESSAGES if m.direction == "command"}
REPLIES: dict[int, Message] = {m.code: m for m in MESSAGES if m.direction == "reply"}
MAX_REPLY_PAYLOAD = max(m.size for m in REPLIES.values())


def crc16(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE (``crc16(b"123456789") == 0x29B1``)."""
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def encode_frame(seq: int, code: int, payload: bytes = b"") -> bytes:
    """One frame; raises :class:`ProtocolError` for an out-of-range SEQ, code or payload."""
    if not 0 <= seq <= 0xFFFF:
        raise ProtocolError(f"sequence number {seq} is not in 0..65535")
    if not 0 <= code <= 0xFF:
        raise ProtocolError(f"message code {code} is not in 0..255")
    if len(payload) > MAX_PAYLOAD:
        raise ProtocolError(f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    body = struct.pack("<BHB", len(payload), seq, code) + bytes(payload)
    return bytes([START]) + body + struct.pack("<H", crc16(body))


def _pack(message: Message, values: Sequence[int]) -> bytes:
    try:
        return message.struct.pack(*values)
    except struct.error as exc:
        raise ProtocolError(
            f"{message.name}: {values!r} does not fit {message.layout}: {exc}"
        ) from exc


def encode(name: str, seq: int, entries: Sequence[Sequence[int]] = ()) -> bytes:
    """Encode a command from the table: ``entries`` holds one tuple of field values per entry
    (a single tuple for fixed payloads, none for empty ones)."""
    message = COMMANDS.get(name)
    if message is None:
        raise ProtocolError(f"unknown command {name!r}; known: {', '.join(COMMANDS)}")
    if not message.repeat and len(entries) != (1 if message.fields else 0):
        raise ProtocolError(f"{name} takes {'one value tuple' if message.fields else 'no payload'}")
    if message.repeat and not 1 <= len(entries) <= MAX_CHANNELS:
        raise ProtocolError(f"{name} takes 1..{MAX_CHANNELS} entries, got {len(entries)}")
    return encode_frame(seq, message.code, b"".join(_pack(message, e) for e in entries))


@dataclass(frozen=True)
class Limits:
    """A channel's limits in microseconds; ``max_step_us`` per 20 ms, 0 = no rate limit."""

    min_us: int
    neutral_us: int
    max_us: int
    max_step_us: int = 0

    def problems(self) -> list[str]:
        """What the firmware would refuse (BAD_VALUE) about these limits; empty if none."""
        out = []
        if not US_ABS_MIN <= self.min_us <= self.neutral_us <= self.max_us <= US_ABS_MAX:
            out.append(
                f"need {US_ABS_MIN} <= min <= neutral <= max <= {US_ABS_MAX} us, got "
                f"{self.min_us}/{self.neutral_us}/{self.max_us}"
            )
        if not 0 <= self.max_step_us <= 0xFFFF:
            out.append(f"max_step_us {self.max_step_us} is not in 0..65535")
        return out


def ping(seq: int) -> bytes:
    """PING: the firmware answers VERSION."""
    return encode("PING", seq)


def status(seq: int) -> bytes:
    """STATUS: the firmware answers STATUS (counters)."""
    return encode("STATUS", seq)


def set_all(seq: int, positions_us: Sequence[int]) -> bytes:
    """SET_ALL: one position per channel (the firmware wants exactly its channel count)."""
    return encode("SET_ALL", seq, [(int(us),) for us in positions_us])


def set_some(seq: int, positions_us: Mapping[int, int]) -> bytes:
    """SET_SOME: positions by channel."""
    return encode("SET_SOME", seq, [(ch, int(us)) for ch, us in positions_us.items()])


def neutral(seq: int) -> bytes:
    """NEUTRAL: every channel to its neutral."""
    return encode("NEUTRAL", seq)


def set_limits(seq: int, limits: Mapping[int, Limits]) -> bytes:
    """SET_LIMITS: min / neutral / max / max_step by channel."""
    return encode(
        "SET_LIMITS",
        seq,
        [
            (ch, lim.min_us, lim.neutral_us, lim.max_us, lim.max_step_us)
            for ch, lim in limits.items()
        ],
    )


def set_watchdog(seq: int, timeout_ms: int) -> bytes:
    """SET_WATCHDOG: return to neutral after this long without SET_ALL / SET_SOME."""
    return encode("SET_WATCHDOG", seq, [(timeout_ms,)])


@dataclass(frozen=True)
class Frame:
    """A CRC-checked frame."""

    seq: int
    code: int
    payload: bytes


class FrameDecoder:
    """Incremental frame decoder that resynchronises after garbage, bad LEN and bad CRC.

    A candidate frame that fails drops its START byte and the bytes after it are scanned again
    (the firmware's parser does the same). ``max_payload`` bounds LEN: replies are at most
    :data:`MAX_REPLY_PAYLOAD` bytes, so garbage can hold back real replies only briefly.
    """

    def __init__(self, max_payload: int = MAX_PAYLOAD) -> None:
        self.max_payload = max_payload
        self.crc_errors = 0
        self.bad_length = 0
        self.dropped_bytes = 0
        self._buf = bytearray()

    @property
    def pending(self) -> int:
        """Bytes held (part of a frame not complete yet)."""
        return len(self._buf)

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        """Add received bytes; return the frames they complete, in order."""
        self._buf += data
        frames: list[Frame] = []
        buf = self._buf
        while buf:
            start = buf.find(START)
            if start < 0:
                self.dropped_bytes += len(buf)
                buf.clear()
                break
            if start > 0:
                self.dropped_bytes += start
                del buf[:start]
            if len(buf) < 2:
                break
            length = buf[1]
            if length > self.max_payload:
                self.bad_length += 1
                del buf[0]
                continue
            size = length + FRAME_OVERHEAD
            if len(buf) < size:
                break
            (crc,) = struct.unpack_from("<H", buf, size - 2)
            if crc16(memoryview(buf)[1 : size - 2]) != crc:
                self.crc_errors += 1
                del buf[0]
                continue
            seq, code = struct.unpack_from("<HB", buf, 2)
            frames.append(Frame(seq, code, bytes(buf[5 : 5 + length])))
            del buf[:size]
        return frames

    def discard_partial(self) -> list[Frame]:
        """Give up on a partial frame (the line went quiet): drop its START, rescan the rest."""
        if not self._buf:
            return []
        del self._buf[0]
        self.dropped_bytes += 1
        return self.feed(b"")
