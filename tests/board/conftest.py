"""The servo-board install (marked ``board``; ``make test-board``; .ci/run runs it)."""

from __future__ import annotations

from pathlib import Path

import pytest


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if Path(str(item.fspath)).is_relative_to(Path(__file__).parent):
            item.add_marker(pytest.mark.board)
            item.add_marker(pytest.mark.timeout(900))
