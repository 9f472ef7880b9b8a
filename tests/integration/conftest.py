"""Fixtures for tests that start facesynth services as separate OS processes."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from facesynth_processes import Processes


@pytest.fixture
def spawn(tmp_path: Path) -> Iterator[Processes]:
    """A :class:`Processes` (call it to start one); its processes are stopped at the end."""
    spawner = Processes(tmp_path)
    yield spawner
    spawner.stop()
