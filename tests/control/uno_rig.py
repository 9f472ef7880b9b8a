"""The real servo firmware on the emulated Uno, reachable by a driver at a fixed port path.

With ``cable=True`` the driver's port is a :class:`~fake_devices.cable.Cable` to the
emulator's pty: the cable can be pulled and plugged in again while the board keeps running,
the board can reboot behind it (:meth:`UnoRig.reboot`), and bytes can be injected. Without,
the driver opens the emulator's own pty, which vanishes when the board is restarted.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from fake_devices.cable import Cable
from host_requirements import FIRMWARE_NEEDS, require_packages
from uno_emulator import EmulatedUno, Pulse, build_firmware

from facesynth.services.control.drivers.arduino import protocol as proto

#: PCA9685 at PRE_SCALE 121: 4.88 µs per step; a width is the request to within half a step.
TICK_US = 122 / 25
_built = False


@pytest.fixture(scope="session")
def firmware_ready() -> None:
    """The firmware and the simavr harness, built once; fails (never skips) without the
    toolchain, naming the Debian packages."""
    global _built
    require_packages("the emulated-Uno driver tests", "test", FIRMWARE_NEEDS)
    if not _built:
        build_firmware()
        _built = True


def near(width: float, us: float) -> bool:
    """A PCA9685 width within half a tick (+ rounding) of ``us``."""
    return abs(width - us) <= TICK_US / 2 + 0.02


def payload_entries(frame: proto.Frame) -> list[tuple[int, ...]]:
    """A command frame's payload as the protocol table lays it out: one tuple per entry."""
    message = next(m for m in proto.COMMANDS.values() if m.code == frame.code)
    size = message.size
    return [
        message.struct.unpack_from(frame.payload, i) for i in range(0, len(frame.payload), size)
    ]


class UnoRig:
    """An emulated Uno for a driver at ``workdir/ttyUno``."""

    def __init__(
        self, workdir: Path, *, cable: bool, output: str = "pca9685", extra: tuple[str, ...] = ()
    ) -> None:
        workdir.mkdir(parents=True, exist_ok=True)
        self.workdir = workdir
        self.port = workdir / "ttyUno"
        self.output = output
        self.extra = extra
        self.boots = 0
        self.cable: Cable | None = None
        self.use_cable = cable
        self.board = self._boot()

    def _boot(self) -> EmulatedUno:
        self.boots += 1
        folder = self.workdir / f"boot{self.boots}"
        folder.mkdir()
        if not self.use_cable:
            return EmulatedUno(folder, self.output, *self.extra, link=self.port, open_port=False)
        board = EmulatedUno(folder, self.output, *self.extra, open_port=False)
        if self.cable is None:
            self.cable = Cable(board.link, self.port)
        else:
            self.cable.switch(board.link)
        return board

    def restart(self) -> None:
        """Power the board off and on (a new emulator; its pty is new too)."""
        assert self.board.close() == 0, self.board.stderr_path.read_text()
        self.board = self._boot()

    def widths(self) -> dict[int, float]:
        return self.board.widths()

    def pulses(self) -> list[Pulse]:
        return self.board.pulses()

    def shows(self, want: dict[int, float]) -> bool:
        """Whether every channel in ``want`` shows its width (within a PCA9685 step)."""
        widths = self.widths()
        return all(near(widths.get(ch, -1), us) for ch, us in want.items())

    def wait_widths(self, want: dict[int, float], timeout: float = 10.0) -> None:
        """Block until :meth:`shows` (for tests whose driver runs in another process)."""
        self.board.wait_for(lambda: self.shows(want), timeout)

    async def settle(self, want: dict[int, float], timeout: float = 10.0) -> None:
        """Wait, letting the event loop run, until :meth:`shows`."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while not self.shows(want):
            if loop.time() > deadline:
                raise TimeoutError(f"widths {self.widths()} never reached {want}")
            await asyncio.sleep(0.02)

    def received(self) -> bytes:
        """Every byte the firmware's UART received since this boot."""
        return bytes(int(e[1], 16) for e in self.board.events("rx"))

    def commands(self) -> list[proto.Frame]:
        """The command frames the firmware received since this boot (CRC-checked)."""
        return proto.FrameDecoder().feed(self.received())

    def close(self) -> None:
        if self.cable is not None:
            self.cable.close()
        assert self.board.close() == 0, self.board.stderr_path.read_text()
