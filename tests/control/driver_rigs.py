"""One rig per registered driver, for the driver contract suite (test_driver_contract.py).

A rig owns the device a driver talks to (a file, a fake board on a pty, the real firmware on
the emulated Uno), says how to configure the driver for it, reads back what the device shows
and, where the device can be unplugged, unplugs it. Adding a driver = adding a rig here
(``RIGS``); the contract suite fails for a registered driver without one.
"""

from __future__ import annotations

import abc
import asyncio
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fake_devices.maestro import FakeMaestro
from fake_devices.ssc32 import FakeSSC32
from uno_rig import TICK_US, UnoRig

from facesynth.runtime.profiles import Profile
from services.control.drivers.base import ServoDriver
from services.control.drivers.record import read_record
from services.control.drivers.registry import DRIVERS


class DriverRig(abc.ABC):
    """The device side of one driver in the contract suite."""

    #: Whether the device can be unplugged and plugged in again (a serial board).
    can_unplug = True
    #: How far a shown position may be from the one sent, in µs (the device's resolution).
    tolerance_us = 0.5

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    @abc.abstractmethod
    def config(self) -> dict[str, Any]:
        """The driver's config as a graph table would hold it (``driver = NAME`` included)."""

    def make(self, profile: Profile) -> ServoDriver:
        """The driver for this device, built through the registry as the CLI builds it."""
        return DRIVERS.build(DRIVERS.parse(self.config()), profile)

    @abc.abstractmethod
    def shown(self, profile: Profile) -> dict[str, float]:
        """What the device shows now, µs by servo name (servos it shows nothing for: absent)."""

    def missing_device(self) -> dict[str, Any] | None:
        """A config naming a device that is not there (None: not applicable)."""
        return {**self.config(), "port": str(self.folder / "no-such-port")}

    @abc.abstractmethod
    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        """Configs the driver must refuse, with a fragment of the expected message."""

    def unplug(self) -> None:
        raise NotImplementedError

    def plug(self) -> None:
        raise NotImplementedError

    def close(self) -> None:  # noqa: B027 - most rigs have something to release
        """Release the device."""

    async def wait_shown(
        self, profile: Profile, want: dict[str, float], timeout: float = 10
    ) -> None:
        """Wait until the device shows ``want`` (within :attr:`tolerance_us`)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            shown = self.shown(profile)
            if all(abs(shown.get(n, -1e9) - us) <= self.tolerance_us for n, us in want.items()):
                return
            if loop.time() > deadline:
                raise AssertionError(f"{type(self).__name__} shows {shown}, want {want}")
            await asyncio.sleep(0.02)


class RecordRig(DriverRig):
    can_unplug = False
    tolerance_us = 0.001

    def config(self) -> dict[str, Any]:
        return {"driver": "record", "out": str(self.folder / "commands.jsonl")}

    def shown(self, profile: Profile) -> dict[str, float]:
        path = self.folder / "commands.jsonl"
        lines = read_record(path) if path.exists() else []
        return dict(lines[-1].servos) if lines else {}

    def missing_device(self) -> dict[str, Any] | None:
        (self.folder / "a-file").write_text("")
        return {"driver": "record", "out": str(self.folder / "a-file" / "commands.jsonl")}

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        return [({"driver": "record"}, "missing required field `out`")]


class MaestroRig(DriverRig):
    tolerance_us = 0.25

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.device = FakeMaestro(folder / "ttyMaestro", channels=24)
        self.device.plug()

    def config(self) -> dict[str, Any]:
        return {"driver": "maestro", "port": str(self.device.link), "model": "mini24"}

    def shown(self, profile: Profile) -> dict[str, float]:
        with self.device.lock:
            targets = list(self.device.targets)
        return {s.name: targets[s.channel] / 4 for s in profile.servos if targets[s.channel]}

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        port = str(self.device.link)
        return [
            ({"driver": "maestro"}, "missing required field `port`"),
            ({"driver": "maestro", "port": port, "model": "mega"}, "Invalid enum value 'mega'"),
            (
                {"driver": "maestro", "port": port, "model": "mini12"},
                "Mini Maestro 12 has channels 0..11",
            ),
            ({"driver": "maestro", "port": port, "baud": 0}, "Expected `int` >= 1"),
            ({"driver": "maestro", "port": "socket://:x"}, "expected socket://HOST:PORT"),
            ({"driver": "maestro", "port": "ftp://a:1"}, "unknown URL scheme 'ftp'"),
        ]

    def unplug(self) -> None:
        self.device.unplug()

    def plug(self) -> None:
        self.device.plug()

    def close(self) -> None:
        self.device.close()


class SSC32Rig(DriverRig):
    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.device = FakeSSC32(folder / "ttySSC32")
        self.device.plug()

    def config(self) -> dict[str, Any]:
        return {"driver": "ssc32", "port": str(self.device.link)}

    def shown(self, profile: Profile) -> dict[str, float]:
        with self.device.lock:
            widths = dict(self.device.widths)
        return {s.name: float(widths[s.channel]) for s in profile.servos if s.channel in widths}

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        port = str(self.device.link)
        return [
            ({"driver": "ssc32", "port": port, "move_time_ms": 0}, "Expected `int` >= 1"),
            ({"driver": "ssc32", "port": port, "speed": 3}, "unknown field `speed`"),
        ]

    def unplug(self) -> None:
        self.device.unplug()

    def plug(self) -> None:
        self.device.plug()

    def close(self) -> None:
        self.device.close()


class ArduinoRig(DriverRig):
    tolerance_us = TICK_US / 2 + 0.52  # integer µs, then a PCA9685 step

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.uno = UnoRig(folder / "uno", cable=True)

    def config(self) -> dict[str, Any]:
        return {"driver": "arduino", "port": str(self.uno.port), "board_watchdog_ms": 60000}

    def shown(self, profile: Profile) -> dict[str, float]:
        widths = self.uno.widths()
        return {s.name: widths[s.channel] for s in profile.servos if s.channel in widths}

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        port = str(self.uno.port)
        return [
            ({"driver": "arduino", "port": port, "board_watchdog_ms": 5}, "Expected `int` >= 20"),
            ({"driver": "arduino", "port": port, "connect_timeout": 0}, "Expected `float` > 0.0"),
        ]

    def unplug(self) -> None:
        assert self.uno.cable is not None
        self.uno.cable.unplug()

    def plug(self) -> None:
        assert self.uno.cable is not None
        self.uno.cable.plug()

    def close(self) -> None:
        self.uno.close()


#: Driver name -> its rig. The virtual and VMC drivers add theirs here.
RIGS: dict[str, Callable[[Path], DriverRig]] = {
    "record": RecordRig,
    "maestro": MaestroRig,
    "ssc32": SSC32Rig,
    "arduino": ArduinoRig,
}
#: Rigs that need the firmware toolchain (built once per session first).
NEEDS_FIRMWARE = {"arduino"}
