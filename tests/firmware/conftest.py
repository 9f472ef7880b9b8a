"""Fixtures for the firmware tests: the toolchain check, the build (once), an emulated Uno."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from host_requirements import FIRMWARE_NEEDS, require_packages
from uno_emulator import EmulatedUno, build_firmware

from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.control.drivers.arduino import replies


@pytest.fixture(scope="session")
def firmware_build() -> str:
    """Builds both firmware variants and the simavr harness once per session.

    Fails (never skips) without the toolchain: CI installs it (.ci/run), so a missing package
    is a broken environment, named in the message.
    """
    require_packages("the firmware tests", "test", FIRMWARE_NEEDS)
    return build_firmware()


@pytest.fixture
def booted_uno(firmware_build: str, tmp_path: Path) -> Iterator[EmulatedUno]:
    """A freshly booted emulated Uno with the PCA9685 firmware, answering PING, as booted."""
    board = EmulatedUno(tmp_path)
    try:
        board.wait_ready()
        yield board
    finally:
        assert board.close() == 0, board.stderr_path.read_text()
    setups = [e for e in board.events("reg") if e[1] == "PRE_SCALE"]
    assert len(setups) == 1, "the firmware set the PCA9685 up more than once: it rebooted"
    used, untouched = board.stack_use()
    assert untouched >= 256, f"stack used {used} bytes, only {untouched} bytes of RAM never touched"


@pytest.fixture
def uno(booted_uno: EmulatedUno) -> EmulatedUno:
    """:func:`booted_uno` with its watchdog at 60 s, so a test stalled by a busy machine does
    not see positions return to neutral (the watchdog has its own tests)."""
    reply = booted_uno.request(proto.set_watchdog(booted_uno.next_seq(), proto.WATCHDOG_MAX_MS))
    assert isinstance(reply, replies.Ack), reply
    return booted_uno
