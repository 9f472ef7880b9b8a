"""Fuzz what users and pages type: the live face page's WebSocket messages, and the option
parsers of the command line (``--http``, ``--size``, ``--keys``, ``--schedule``)."""

from __future__ import annotations

import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st

from facesynth.app.recording.convert import ConvertError, parse_size
from facesynth.app.recording.recorder import RecordOptionError, parse_keys
from facesynth.services.control.drivers.virtual import AddressError, parse_address
from facesynth.services.control.drivers.virtual.wire import (
    ClientMessageError,
    Hello,
    Ping,
    parse_client,
)
from facesynth.services.features.calibrate import CalibrationStepError, parse_schedule

pytestmark = [pytest.mark.fuzz, TIMEOUT]

#: JSON-ish pieces that page messages are made of, and their hostile variants.
PIECES = ['{"type": "ping", "t": ', '{"type": "hello", "frames": ', "1.5", "1e999", "NaN", "-0",
          "true", "null", '"x"', "}", "{", '"type"', ": ", ", ", '"frames": false',
          '"extra": 1', "\ud800", "\x00", "[]", '"hello"', '"ping"']  # fmt: skip


def test_page_messages_parse_or_raise_client_message_error() -> None:
    target = "virtual wire.parse_client (page message)"

    @FUZZ
    @given(
        st.one_of(
            st.lists(st.sampled_from(PIECES), max_size=8).map("".join),
            st.builds(
                '{{"type": "{}", "{}": {}}}'.format,
                st.sampled_from(["ping", "hello", "pong"]),
                st.sampled_from(["t", "frames", "x"]),
                st.sampled_from(["1.5", "true", "1e999", "NaN", "null", '"1"', "-3"]),
            ),
            st.text(max_size=80),
            st.text(min_size=1020, max_size=1100),
        )
    )
    def case(text: str) -> None:
        message = outcome(target, lambda: parse_client(text), ClientMessageError)
        assert message is None or isinstance(message, Hello | Ping)

    case()
    check_tally(target, "valid", "refused")


def _text_of(*pieces: str) -> st.SearchStrategy[str]:
    """Up to six pieces, exactly three (a value's usual shape: ``640`` ``x`` ``480``, an
    address and a port, two schedule steps; rare among up to six), or any text."""
    return st.one_of(
        st.lists(st.sampled_from(pieces), max_size=6).map("".join),
        st.lists(st.sampled_from(pieces), min_size=3, max_size=3).map("".join),
        st.text(max_size=30),
    )


@pytest.mark.parametrize(
    ("name", "parse", "error", "pieces"),
    [
        ("virtual parse_address (--http)", parse_address, AddressError,
         ("localhost", "[::1]", ":", "8080", "65536", "-1", "²", "٣", "0", "", " ", "]", "[")),
        ("recording parse_size (--size)", parse_size, ConvertError,
         ("640", "x", "X", "480", "0", "-1", "99999", "²", " ", "1e3", "_1")),
        ("recording parse_keys (--keys)", parse_keys, RecordOptionError,
         ("input", "points", "features", "servo_commands", ",", " ", "stats", "x")),
        ("features parse_schedule (--schedule)", parse_schedule, CalibrationStepError,
         ("neutral=1-2", "smile=3-4.5", "brow=2-5", "neutral", "=", "1", "-", ",", "٣", " ")),
    ],
    ids=["http", "size", "keys", "schedule"],
)  # fmt: skip
def test_option_values_parse_or_raise_their_error(
    name: str, parse: object, error: type[ValueError], pieces: tuple[str, ...]
) -> None:
    @FUZZ
    @given(_text_of(*pieces))
    def case(text: str) -> None:
        outcome(name, lambda: parse(text), error)  # type: ignore[operator]

    case()
    check_tally(name, "valid", "refused")
