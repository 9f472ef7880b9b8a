"""The JSON file readers refuse bytes that are not UTF-8 with its own error.

msgspec raises ``UnicodeDecodeError`` (not its ``DecodeError``) for a string or key that is not
UTF-8, so each reader names it among the errors it turns into its documented one (found by
tests/fuzz).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from facesynth.runtime.calibration import CalibrationError, parse_calibration
from services.control.drivers.record import RecordError, read_sessions
from services.features.state import StateError, parse_state

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
