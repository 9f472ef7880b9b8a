"""The fuzz suite's summary: one line per target (cases and outcomes), after the tests."""

from __future__ import annotations

from typing import Any

from fuzzing import TALLIES


def pytest_terminal_summary(terminalreporter: Any) -> None:
    if not TALLIES:
        return
    terminalreporter.write_sep("=", f"fuzz targets ({len(TALLIES)})")
    for record in TALLIES.values():
        terminalreporter.write_line(record.line())
