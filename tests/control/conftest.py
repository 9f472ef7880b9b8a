"""Fixtures for the driver tests: fake Maestro and SSC-32 boards on ptys, the emulated Uno
(the real firmware on simavr, tests/firmware/uno_emulator.py), from board_fixtures.py; facesynth
processes come from tests/conftest.py."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "firmware"))

from board_fixtures import maestro, ssc32, uno
from uno_rig import firmware_ready

__all__ = ["firmware_ready", "maestro", "ssc32", "uno"]
