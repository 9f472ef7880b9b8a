"""The console page's messages: every kind parses; anything else is one clear error."""

from __future__ import annotations

import pytest

from facesynth.app.console import protocol as p


@pytest.mark.parametrize(
    ("text", "parsed"),
    [
        ('{"type": "hello", "token": "t"}', p.Hello(token="t")),
        ('{"type": "jog", "servo": 2, "us": 1500}', p.Jog(servo=2, us=1500.0)),
        ('{"type": "limit", "servo": 0, "which": "max"}', p.SetLimit(servo=0, which="max")),
        ('{"type": "limit", "servo": 0, "which": "min", "us": 990.5}',
         p.SetLimit(servo=0, which="min", us=990.5)),
        ('{"type": "reverse", "servo": 1, "reversed": true}', p.Reverse(servo=1, reversed=True)),
        ('{"type": "stop"}', p.Stop()),
        ('{"type": "calibrate", "name": "alice"}', p.Calibrate(name="alice")),
    ],
)  # fmt: skip
def test_messages_parse(text: str, parsed: p.ClientMessage) -> None:
    assert p.parse(text) == parsed


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "not JSON"),
        ("{", "not JSON"),
        ("null", "not a console message (Expected `object`, got `null`)"),
        ('{"type": 3}', "malformed message"),
        ('{"kind": "jog"}', "missing required field `type`"),
        ('{"type": "jump"}', "types: hello, take, release, jog"),
        ('{"type": "jog", "servo": 1.5, "us": 1}', "Expected `int`, got `float`"),
        ('{"type": "jog", "servo": 1, "us": "far"}', "Expected `float`, got `str`"),
        ('{"type": "reverse", "servo": 1, "reversed": "yes"}', "Expected `bool`"),
        ('{"type": "save", "now": true}', "unknown field `now`"),
        ("x" * (p.MAX_MESSAGE + 1), f"at most {p.MAX_MESSAGE}"),
        ("é" * (p.MAX_MESSAGE // 2 + 1), "bytes (at most"),  # counted in bytes, not characters
        ('{"type": "rename", "servo": 0, "name": "\ud800"}', "not text: a lone surrogate"),
    ],
)
def test_malformed_messages_are_refused_clearly(text: str, message: str) -> None:
    with pytest.raises(p.MessageError, match=message.replace("(", r"\(").replace(")", r"\)")):
        p.parse(text)


def test_every_type_is_listed() -> None:
    assert tuple(cls.__struct_config__.tag for cls in p.ClientMessage.__args__) == p.TYPES
