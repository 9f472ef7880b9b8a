"""Encode and decode facesynth messages, and check the ones handed over within a process.

Every service decodes what it receives through :func:`decode`; anything malformed (over its
size limit, not msgpack, wrong tag, wrong field types, or failing the checks of its values in
:mod:`facesynth.runtime.message_checks`: NaN/inf, wrong coordinate counts, too many entries, a
raw frame of the wrong size, a JPEG whose header disagrees with the frame's size) raises
:class:`MessageError` with a precise reason, which the services count, log and drop. The size
limit (:mod:`facesynth.runtime.limits`) is checked on the bytes before msgspec builds anything,
and a JPEG's dimensions are read from its header before anyone decodes it. A message built in
this process and handed over as an object gets the same checks, without bytes (:func:`check`).
"""

from __future__ import annotations

import collections
import contextlib
import functools
from typing import Any, TypeVar

import msgspec

from facesynth.runtime import limits
from facesynth.runtime.field_types import FieldTypes
from facesynth.runtime.message_checks import (
    MAX_COORD,
    MAX_FRAME_PIXELS,
    MAX_FRAME_SIDE,
    MAX_PULSE_US,
    VALIDATORS,
    MessageError,
    validate_features,
    validate_points,
)
from facesynth.runtime.oneline import one_line
from facesynth.schemas.messages import (
    BabbleSample,
    Features,
    Frame,
    Points,
    ServiceStats,
    ServoCommands,
)

__all__ = [
    "MAX_BYTES",
    "MAX_COORD",
    "MAX_FRAME_PIXELS",
    "MAX_FRAME_SIDE",
    "MAX_PULSE_US",
    "MessageError",
    "check",
    "decode",
    "encode",
    "validate_features",
    "validate_points",
]

M = TypeVar("M", Frame, Points, Features, ServoCommands, ServiceStats, BabbleSample)

_ENCODER = msgspec.msgpack.Encoder()
_DECODERS: dict[type[Any], msgspec.msgpack.Decoder[Any]] = {
    cls: msgspec.msgpack.Decoder(cls)
    for cls in (Frame, Points, Features, ServoCommands, ServiceStats, BabbleSample)
}
#: Payload limit of each message type (bytes), checked before decoding.
MAX_BYTES: dict[type[Any], int] = {
    Frame: limits.STAGE_LIMITS["input"],
    Points: limits.STAGE_LIMITS["points"],
    Features: limits.STAGE_LIMITS["features"],
    ServoCommands: limits.STAGE_LIMITS["servo_commands"],
    ServiceStats: limits.STATS_LIMIT,
    BabbleSample: limits.STAGE_LIMITS["babble"],
}


@functools.cache
def _field_types(cls: type[Any]) -> FieldTypes:
    """Every field's declared type of ``cls``, checked on objects handed over within a process
    (:func:`check`); built on first use (a process that only decodes bytes never needs it)."""
    return FieldTypes(cls)


def encode(message: msgspec.Struct) -> bytes:
    """msgpack bytes of a message struct."""
    return _ENCODER.encode(message)


def decode(payload: bytes | bytearray | memoryview, cls: type[M]) -> M:
    """Decode and validate one message of type ``cls``, or raise :class:`MessageError`.

    A payload over the type's size limit is refused before it is decoded.
    """
    limit = MAX_BYTES[cls]
    if len(payload) > limit:
        raise MessageError(
            f"a {cls.__name__} message of {len(payload)} bytes is over its limit of "
            f"{limit} bytes: refused undecoded"
        )
    try:
        message = _DECODERS[cls].decode(payload)
    except (msgspec.DecodeError, msgspec.ValidationError, UnicodeDecodeError) as exc:
        # msgspec raises UnicodeDecodeError for a tag string that is not UTF-8
        raise MessageError(f"not a valid {cls.__name__} message: {one_line(str(exc))}") from None
    VALIDATORS[cls](message)
    return message


#: The messages :func:`check` passed last, by id, each kept alive here (so its id cannot be
#: another object's while it is remembered): a message read by several mailboxes of the
#: process (a controller's report: the translator, the sensor's credit, run's drain watch) is
#: checked once. Messages are immutable, so a verdict holds for the object's lifetime.
_PASSED: collections.OrderedDict[int, object] = collections.OrderedDict()
_PASSED_KEPT = 8


def check(message: object, cls: type[M]) -> M:
    """Check a message built in this process (never encoded) as :func:`decode` checks a decoded
    one, or raise :class:`MessageError`: it must be a ``cls``, have every field of its declared
    type as decoding would (:mod:`facesynth.runtime.field_types`, msgspec's error text), and
    pass the same semantic checks (finite numbers, counts, sizes). The byte limit does not apply
    (an object has no bytes; the checks bound its counts).
    """
    if not isinstance(message, cls):
        raise MessageError(f"not a valid {cls.__name__} message: a {type(message).__name__} object")
    if _PASSED.get(id(message)) is message:
        return message
    try:
        _field_types(cls).check(message)
        VALIDATORS[cls](message)
    except MessageError:
        raise
    except msgspec.ValidationError as exc:
        raise MessageError(f"not a valid {cls.__name__} message: {one_line(str(exc))}") from None
    except (TypeError, AttributeError, KeyError, ValueError) as exc:
        raise MessageError(f"not a valid {cls.__name__} message: {one_line(str(exc))}") from None
    _PASSED[id(message)] = message
    if len(_PASSED) > _PASSED_KEPT:
        with contextlib.suppress(KeyError):  # another thread took it out first
            _PASSED.popitem(last=False)
    return message
