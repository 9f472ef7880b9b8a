"""Fixtures for the doctor tests: the real parts doctor looks at (the firmware on the emulated
Uno, the simulated head's Maestro and camera, an SSC-32 on a pty), from tests/control."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "control"))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "firmware"))

from board_fixtures import ssc32
from facesynth_processes import Processes
from uno_rig import UnoRig, firmware_ready

__all__ = ["firmware_ready", "ssc32"]


@pytest.fixture
def uno(firmware_ready: None, tmp_path: Path) -> Iterator[UnoRig]:
    """Our firmware (PCA9685 build) on an emulated Uno, behind a cable at ``tmp_path/uno``,
    booted (its PCA9685 set up and all 16 channels at neutral, as the emulator's log shows)
    before doctor looks at it: a test that compares the pulses before and after doctor must
    not count the boot's, which a busy machine logs late."""
    rig = UnoRig(tmp_path / "uno", cable=True)

    def booted() -> bool:
        set_up = any(e[1] == "PRE_SCALE" for e in rig.board.events("reg"))
        return set_up and len(rig.widths()) == 16

    rig.board.wait_for(booted, timeout=20)
    yield rig
    rig.close()


@pytest.fixture
def simhead(tmp_path: Path) -> Iterator[tuple[Path, str]]:
    """``facesynth simhead`` as its own process: its Maestro's pty link and its camera URL."""
    processes = Processes(tmp_path)
    link = tmp_path / "simhead-tty"
    try:
        yield link, processes.start_simhead(link)
    finally:
        processes.stop()
