"""runtime.codec.check: a message handed over within a process (never encoded) is refused
exactly as its bytes would be, with one clear line, and checked once however many read it."""

from __future__ import annotations

import math
from typing import Any

import msgspec
import pytest

from facesynth.runtime import codec
from facesynth.runtime.codec import MessageError
from facesynth.schemas.messages import Features, Points, PointSet, ServoCommands


def _commands(**positions: Any) -> ServoCommands:
    return ServoCommands(
        seq=1, t_capture_ns=1, t_media_ns=1, face=True, profile="p", positions=positions
    )


def _points(sets: Any) -> Points:
    return Points(
        seq=1, t_capture_ns=1, t_media_ns=1, face=True, image_width=4, image_height=2, sets=sets
    )


@pytest.mark.parametrize(
    ("message", "cls", "reason"),
    [
        (_commands(jaw=math.nan), ServoCommands, "position of 'jaw' is nan"),
        (_commands(jaw=-1.0), ServoCommands, "position of 'jaw' is negative"),
        (
            _commands(jaw="1500"),
            ServoCommands,
            "not a valid ServoCommands message: Expected `float",
        ),
        (
            msgspec.structs.replace(_commands(jaw=1.0), sender=[0.0]),
            ServoCommands,
            r"Expected `str`, got `array` - at `\$.sender`",
        ),
        (_commands(jaw=1500.0), Features, "not a valid Features message: a ServoCommands object"),
        ("garbage", ServoCommands, "not a valid ServoCommands message: a str object"),
        (_points([PointSet(scheme="ibug68", dims=2, coords=[0.0] * 3)]), Points, "not a positive"),
        (_points([{"scheme": "ibug68"}]), Points, "not a valid Points message: 'dict' object"),
        (_points([PointSet(scheme="x", dims=2, coords=[math.inf, 0.0])]), Points, "finite"),
    ],
    ids=[
        "nan",
        "negative",
        "str",
        "list sender",
        "other type",
        "not a message",
        "odd count",
        "dict",
        "inf",
    ],
)
def test_an_object_is_refused_with_one_line(message: Any, cls: type[Any], reason: str) -> None:
    with pytest.raises(MessageError, match=reason) as info:
        codec.check(message, cls)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("message", "cls"),
    [
        (_commands(jaw=math.inf), ServoCommands),
        (
            msgspec.structs.replace(
                _points([PointSet(scheme="x", dims=2, coords=[1.0, 2.0])]), face=False
            ),
            Points,
        ),
    ],
    ids=["inf", "points without a face"],
)
def test_an_object_refused_as_an_object_is_refused_as_bytes(message: Any, cls: type[Any]) -> None:
    with pytest.raises(MessageError) as as_object:
        codec.check(message, cls)
    with pytest.raises(MessageError) as as_bytes:
        codec.decode(codec.encode(message), cls)
    assert str(as_object.value) == str(as_bytes.value)


def test_a_message_is_checked_once_however_many_read_it(monkeypatch: pytest.MonkeyPatch) -> None:
    validated: list[object] = []
    validate = codec._VALIDATORS[ServoCommands]

    def counting(message: ServoCommands) -> None:
        validated.append(message)
        validate(message)

    monkeypatch.setitem(codec._VALIDATORS, ServoCommands, counting)
    message = _commands(jaw=1500.0)
    for _ in range(3):  # three mailboxes of one process take the same report
        assert codec.check(message, ServoCommands) is message
    assert validated == [message]
    twin = _commands(jaw=1500.0)  # equal, but another object: checked on its own
    assert codec.check(twin, ServoCommands) is twin
    assert len(validated) == 2
    bad = _commands(jaw=math.nan)  # a refusal is not remembered: refused every time
    for _ in range(2):
        with pytest.raises(MessageError):
            codec.check(bad, ServoCommands)
    assert len(validated) == 4


def test_messages_are_frozen() -> None:
    message = _commands(jaw=1500.0)
    with pytest.raises(AttributeError):
        message.seq = 2  # type: ignore[misc]
    assert msgspec.structs.replace(message, seq=2).seq == 2
