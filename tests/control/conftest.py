"""Fixtures for the driver tests: fake Maestro and SSC-32 boards on ptys, the emulated Uno
(the real firmware on simavr, tests/firmware/uno_emulator.py), profiles, facesynth processes."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "firmware"))

from facesynth_processes import Processes
from fake_devices.maestro import FakeMaestro
from fake_devices.ssc32 import FakeSSC32
from uno_rig import UnoRig, firmware_ready

__all__ = ["firmware_ready"]


@pytest.fixture
def maestro(tmp_path: Path) -> Iterator[FakeMaestro]:
    """A fake Mini Maestro 24, plugged in at ``tmp_path/ttyMaestro``."""
    device = FakeMaestro(tmp_path / "ttyMaestro", channels=24)
    device.plug()
    yield device
    device.close()


@pytest.fixture
def ssc32(tmp_path: Path) -> Iterator[FakeSSC32]:
    """A fake SSC-32U, plugged in at ``tmp_path/ttySSC32``."""
    device = FakeSSC32(tmp_path / "ttySSC32")
    device.plug()
    yield device
    device.close()


@pytest.fixture
def uno(firmware_ready: None, tmp_path: Path) -> Iterator[UnoRig]:
    """The PCA9685 firmware on an emulated Uno, behind a cable at ``tmp_path/ttyUno``."""
    rig = UnoRig(tmp_path / "uno", cable=True)
    yield rig
    rig.close()


@pytest.fixture
def processes(tmp_path: Path) -> Iterator[Processes]:
    """A :class:`Processes` for this test."""
    spawner = Processes(tmp_path)
    yield spawner
    spawner.stop()
