"""Fixtures for the learn tests: facesynth commands as real OS processes."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from facesynth_processes import Processes


@pytest.fixture
def processes(tmp_path: Path) -> Iterator[Processes]:
    """A :class:`Processes`; what is still running at the end gets SIGTERM, then SIGKILL."""
    spawner = Processes(tmp_path)
    yield spawner
    spawner.stop()
