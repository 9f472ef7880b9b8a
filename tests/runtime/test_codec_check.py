"""runtime.codec.check: a message handed over within a process (never encoded) is refused
exactly as its bytes would be, with one clear line, and checked once however many read it."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest

from facesynth.runtime import codec
from facesynth.runtime.codec import MessageError
from facesynth.schemas.messages import (
    ALL_MESSAGES,
    BabbleSample,
    Features,
    Frame,
    Points,
    PointSet,
    ScoreSet,
    ServiceStats,
    ServoCommands,
)


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
        (
            _points([{"scheme": "ibug68"}]),
            Points,
            r"not a valid Points message: Object missing required field `dims` - at `\$.sets\[0\]`",
        ),
        (
            _points([{"scheme": "ibug68", "dims": 2, "coords": [1.0, 2.0]}]),
            Points,
            r"not a valid Points message: Expected `PointSet`, got `dict` - at `\$.sets\[0\]`",
        ),
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
        "incomplete dict",
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


FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "messages"


def _golden(name: str, cls: type[Any], **fields: Any) -> Any:
    """A golden message of ``cls`` as a stage could build it, with ``fields`` (the constructor
    and ``replace`` check no types)."""
    message = codec.decode((FIXTURES / f"{name}.msgpack").read_bytes(), cls)
    return msgspec.structs.replace(message, **fields)


def _family(reason: str) -> str:
    """``reason`` without the name msgspec gives the value it got."""
    return re.sub(r"got `[^`]*`", "got `…`", reason)


#: For every message type, objects with a field of the wrong type, and the field's path.
WRONG_TYPED = [
    (_golden("frame_raw", Frame, width="4"), "$.width"),
    (_golden("frame_raw", Frame, encoding="png"), "$.encoding"),
    (_golden("frame_jpeg", Frame, data="AAAA"), "$.data"),
    (_golden("frame_raw", Frame, fps=True), "$.fps"),
    (_golden("points_face", Points, face="yes"), "$.face"),
    (_golden("points_face", Points, confidence="0.9"), "$.confidence"),
    (_golden("points_no_face", Points, image_height=360.0), "$.image_height"),
    (
        _golden(
            "points_face", Points, sets=[PointSet(scheme="ibug68", dims=2.0, coords=[1.0] * 4)]
        ),  # type: ignore[arg-type]
        "$.sets[0].dims",
    ),
    (
        _golden("points_face", Points, scores=[ScoreSet(scheme="s", values=[0.5, "1"])]),  # type: ignore[list-item]
        "$.scores[0].values[1]",
    ),
    (_golden("points_no_face", Points, source=None), "$.source"),
    (_golden("features", Features, neutral_ready=1), "$.neutral_ready"),
    (_golden("features", Features, named={"jaw": "0.5"}), "$.named[...]"),
    (_golden("features", Features, distances=[1.0, "2"]), "$.distances[1]"),
    (_golden("features", Features, raw={3: 0.5}), "`key` in `$.raw`"),
    (_golden("servo_commands", ServoCommands, move=3), "$.move"),
    (_golden("servo_commands_sent", ServoCommands, sent_ns=1.5), "$.sent_ns"),
    (_golden("servo_state_own_move", ServoCommands, faults={"jaw": 1}), "$.faults[...]"),
    (_golden("service_stats", ServiceStats, latency_p50_ms="1"), "$.latency_p50_ms"),
    (_golden("service_stats", ServiceStats, router_connected="yes"), "$.router_connected"),
    (_golden("service_stats_idle", ServiceStats, received=-0.5), "$.received"),
    (_golden("babble_sample", BabbleSample, settled="no"), "$.settled"),
    (_golden("babble_sample", BabbleSample, commanded={"jaw": "1500"}), "$.commanded[...]"),
    (_golden("babble_sample", BabbleSample, frames=2.0), "$.frames"),
]


@pytest.mark.parametrize(
    ("message", "path"),
    WRONG_TYPED,
    ids=[f"{type(m).__name__} {path}" for m, path in WRONG_TYPED],
)
def test_a_wrong_typed_field_is_refused_as_its_bytes_are(message: Any, path: str) -> None:
    cls = type(message)
    with pytest.raises(MessageError) as as_bytes:
        codec.decode(codec.encode(message), cls)
    with pytest.raises(MessageError) as as_object:
        codec.check(message, cls)
    # msgspec names a received None `null` when converting, `None` when decoding: the same
    # error otherwise, word for word
    assert _family(str(as_object.value)) == _family(str(as_bytes.value))
    assert str(as_object.value).startswith(f"not a valid {cls.__name__} message: ")
    assert str(as_object.value).endswith(path if path.startswith("`") else f"`{path}`")


def test_every_message_type_has_a_wrong_typed_row() -> None:
    assert {type(message) for message, _ in WRONG_TYPED} == set(ALL_MESSAGES)


def test_a_numpy_number_is_refused_as_an_object() -> None:
    # Its bytes cannot even be written (msgspec encodes no numpy scalars): a stage that puts
    # one in a message breaks every reader in another process, so readers here refuse it too.
    message = _golden("features", Features, named={"jaw": np.float64(0.5)})
    with pytest.raises(TypeError):
        codec.encode(message)
    with pytest.raises(MessageError, match=r"Expected `float`, got `numpy.float64` - at `\$.named"):
        codec.check(message, Features)


def test_a_message_is_checked_once_however_many_read_it(monkeypatch: pytest.MonkeyPatch) -> None:
    validated: list[object] = []
    validate = codec.VALIDATORS[ServoCommands]

    def counting(message: ServoCommands) -> None:
        validated.append(message)
        validate(message)

    monkeypatch.setitem(codec.VALIDATORS, ServoCommands, counting)
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
