"""Profile tests see the shipped profiles only."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def _shipped_profiles_only(isolated_home: Path) -> None:
    """No user profiles: see ``isolated_home`` in tests/conftest.py."""
