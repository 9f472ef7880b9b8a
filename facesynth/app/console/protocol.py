"""The console page's messages: JSON objects with a ``type``, parsed strictly.

A page sends :data:`ClientMessage` s over its WebSocket; anything else (not JSON, an unknown
type, a missing or stray field, a wrong type, a message over :data:`MAX_MESSAGE` bytes) is a
:class:`MessageError` whose text the page is sent back as an ``error`` message. The server's
messages are built by :func:`message`.
"""

from __future__ import annotations

from typing import Any, Literal

import msgspec

#: Longest message a page may send (bytes).
MAX_MESSAGE = 2048

Limit = Literal["min", "neutral", "max"]


class MessageError(ValueError):
    """A page's message that is not one of :data:`ClientMessage`."""


class _Message(msgspec.Struct, tag_field="type", forbid_unknown_fields=True, kw_only=True):
    pass


class Hello(_Message, tag="hello"):
    """The page says who it is: ``token`` (from the URL it was opened with) may move servos."""

    token: str = ""
    frames: bool = True


class Take(_Message, tag="take"):
    """Take the servos: hold them where they stand (one page at a time)."""


class Release(_Message, tag="release"):
    """Let go: the console stops commanding (C's watchdog returns the face to neutral)."""


class Jog(_Message, tag="jog"):
    """Servo ``servo`` (its index) to ``us`` microseconds."""

    servo: int
    us: float


class Centre(_Message, tag="centre"):
    """Every servo to the middle of its range."""


class Neutral(_Message, tag="neutral"):
    """Every servo to its neutral."""


class Stop(_Message, tag="stop"):
    """Every servo stops where it stands."""


class SetLimit(_Message, tag="limit"):
    """Servo ``servo``'s ``which`` limit to ``us`` (omitted: where it stands)."""

    servo: int
    which: Limit
    us: float | None = None


class Rename(_Message, tag="rename"):
    """Servo ``servo`` is called ``name``."""

    servo: int
    name: str


class Reverse(_Message, tag="reverse"):
    """Servo ``servo`` is (or is not) reversed."""

    servo: int
    reversed: bool


class Save(_Message, tag="save"):
    """Save the draft profile (C restarts with it)."""


class Calibrate(_Message, tag="calibrate"):
    """Run the performer calibration called ``name`` from the console's camera or video."""

    name: str


class Ping(_Message, tag="ping"):
    """A round trip; ``t`` comes back in a ``pong``."""

    t: float


ClientMessage = (
    Hello
    | Take
    | Release
    | Jog
    | Centre
    | Neutral
    | Stop
    | SetLimit
    | Rename
    | Reverse
    | Save
    | Calibrate
    | Ping
)
_DECODER = msgspec.json.Decoder(ClientMessage)
TYPES = ("hello", "take", "release", "jog", "centre", "neutral", "stop", "limit", "rename",
         "reverse", "save", "calibrate", "ping")  # fmt: skip


def parse(text: str | bytes) -> ClientMessage:
    """One page message, or :class:`MessageError` saying what is wrong with it."""
    if isinstance(text, str):
        try:
            text = text.encode()
        except UnicodeEncodeError:
            raise MessageError("not text: a lone surrogate in the message") from None
    if len(text) > MAX_MESSAGE:
        raise MessageError(f"a message of {len(text)} bytes (at most {MAX_MESSAGE})")
    try:
        return _DECODER.decode(text)
    except msgspec.ValidationError as exc:
        detail = str(exc)
        if ("Invalid value" in detail and "$.type" in detail) or "Expected `object`" in detail:
            types = ", ".join(TYPES)
            raise MessageError(f"not a console message ({detail}); types: {types}") from None
        raise MessageError(f"malformed message: {detail}") from None
    except msgspec.DecodeError as exc:
        raise MessageError(f"not JSON: {exc}") from None


def message(kind: str, **fields: Any) -> str:
    """A server message of type ``kind``."""
    return msgspec.json.encode({"type": kind, **fields}).decode()
