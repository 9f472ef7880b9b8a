"""Readers of files and messages refuse bytes that are not UTF-8 with their own error, and
keep that error on one line whatever the input quotes.

msgspec raises ``UnicodeDecodeError`` (not its ``DecodeError``) for a string or key that is not
UTF-8, so each reader names it among the errors it turns into its documented one (found by
tests/fuzz).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import msgspec
import pytest

from facesynth.app.graph import GraphError, parse_graph
from facesynth.runtime import codec
from facesynth.runtime.calibration import CalibrationError, parse_calibration
from facesynth.runtime.codec import MessageError
from facesynth.schemas.messages import Points
from facesynth.services.control.drivers.record import RecordError, read_sessions
from facesynth.services.features.state import StateError, parse_state

NOT_UTF8 = b'{"\xf3name": "ann"}\n'


def _record(path: Path) -> object:
    path.write_bytes(NOT_UTF8 + b'{"session": {"started_ns": 1}}\n' + NOT_UTF8)
    return read_sessions(path)


@pytest.mark.parametrize(
    ("read", "error"),
    [
        (lambda path: parse_calibration(NOT_UTF8), CalibrationError),
        (lambda path: parse_state(NOT_UTF8), StateError),
        (_record, RecordError),
    ],
    ids=["calibration", "learned-state", "record-file"],
)
def test_bytes_that_are_not_utf8_are_the_readers_error(
    tmp_path: Path, read: Callable[[Path], object], error: type[ValueError]
) -> None:
    with pytest.raises(error, match=r"utf-8|neither a command"):
        read(tmp_path / "file")


@pytest.mark.parametrize(
    ("read", "error"),
    [
        (lambda: parse_state(b'{"bad\\nkey": 1}'), StateError),
        (lambda: parse_calibration(b'{"bad\\nkey": 1}'), CalibrationError),
        (lambda: codec.decode(msgspec.msgpack.encode({"type": "x\ny"}), Points), MessageError),
        (lambda: parse_graph({"bad\nkey": 1}), GraphError),
        (lambda: parse_graph({"nodes": {"a\nb": {"stage": "x"}}}), GraphError),
    ],
    ids=["learned-state", "calibration", "message", "graph-key", "graph-node"],
)
def test_keys_and_values_with_newlines_stay_on_one_line(
    read: Callable[[], object], error: type[ValueError]
) -> None:
    """msgspec quotes keys and values as they are (found by tests/fuzz)."""
    with pytest.raises(error) as info:
        read()
    assert "\n" not in str(info.value) and "\\n" in str(info.value)
