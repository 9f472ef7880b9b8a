"""Fixtures of the servo boards on ptys: the fake Maestro and SSC-32, our firmware on the
emulated Uno. tests/control's conftest takes them; tests elsewhere put tests/control on
``sys.path`` and import the ones they use (with ``firmware_ready`` from :mod:`uno_rig`)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from fake_devices.maestro import FakeMaestro
from fake_devices.ssc32 import FakeSSC32
from uno_rig import UnoRig


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
    """The PCA9685 firmware on an emulated Uno, behind a cable at ``tmp_path/uno/ttyUno``."""
    rig = UnoRig(tmp_path / "uno", cable=True)
    yield rig
    rig.close()
