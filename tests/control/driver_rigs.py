"""One rig per registered driver, for the driver contract suite (test_driver_contract.py).

A rig owns what a driver talks to (a file, a web page, an OSC receiver, a fake board on a pty,
the real firmware on the emulated Uno), says how to configure the driver for it, and reads
back what came out, in the outside's own form. Adding a driver = adding a rig to ``RIGS``;
the contract suite fails for a registered driver without one.
"""

from __future__ import annotations

import abc
import asyncio
import contextlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import aiohttp
import pytest
from fake_devices.dynamixel import FakeDynamixelBus
from fake_devices.feetech import FakeFeetechBus
from fake_devices.maestro import FakeMaestro
from fake_devices.pca9685 import FakeI2CAdapter, FakePCA9685
from fake_devices.ssc32 import FakeSSC32
from osc_receiver import Receiver, osc_receiver
from uno_rig import TICK_US, UnoRig

from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.drivers.pca9685 import PCA9685Config, PCA9685Driver
from facesynth.services.control.drivers.record import read_record
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.virtual import VirtualDriver
from facesynth.services.control.drivers.vmc import AvatarMapping

PAPER16 = load_profile("paper16")
VIRTUAL = load_profile("virtual")


class DriverRig(abc.ABC):
    """The outside of one driver in the contract suite: its device and how to read it back."""

    #: The profile the driver is built for.
    profile: Profile = PAPER16
    #: Whether the device can be unplugged and plugged in again (a serial board).
    can_unplug = False
    #: Whether :meth:`missing_device` names a device that is not there.
    has_device_path = False
    #: Whether the firmware toolchain must be built first.
    needs_firmware = False
    #: How far a shown position may be from the one sent, in µs (the device's resolution).
    tolerance_us = 0.5

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    @abc.abstractmethod
    def config(self) -> dict[str, Any]:
        """The driver's config as a graph table would hold it (``driver = NAME`` included)."""

    def make(self) -> ServoDriver:
        """The driver for this device, built through the registry as the CLI builds it."""
        return DRIVERS.build(DRIVERS.parse(self.config()), self.profile)

    async def after_connect(self, driver: ServoDriver, count: int) -> None:  # noqa: B027
        """Attach an observer once the driver is up (``count`` commands were sent before)."""

    async def aclose(self) -> None:  # noqa: B027 - most rigs have something to release
        """Release the device and observers."""

    def expected(self, positions: Mapping[str, float]) -> Any:
        """What the outside should show for ``positions`` (already within the limits)."""
        return {name: pytest.approx(us, abs=self.tolerance_us) for name, us in positions.items()}

    @abc.abstractmethod
    async def observed(self, count: int) -> Any:
        """What the outside shows, once ``count`` commands may have arrived."""

    async def shows(self, positions: Mapping[str, float], count: int, timeout: float = 10) -> None:
        """Wait until the outside shows ``positions`` (the ``count``-th command)."""
        want = self.expected(positions)
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            seen = await self.observed(count)
            if seen == want:
                return
            if loop.time() > deadline:
                raise AssertionError(f"{type(self).__name__} shows {seen}, want {want}")
            await asyncio.sleep(0.02)

    def missing_device(self) -> dict[str, Any]:
        """A config naming a device that is not there (rigs with :attr:`has_device_path`)."""
        return {**self.config(), "port": str(self.folder / "no-such-port")}

    @abc.abstractmethod
    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        """Configs the driver must refuse, with a fragment of the expected message."""

    def unplug(self) -> None:
        raise NotImplementedError

    def plug(self) -> None:
        raise NotImplementedError


class RecordRig(DriverRig):
    profile = VIRTUAL

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.before = 0

    def config(self) -> dict[str, Any]:
        return {"driver": "record", "out": str(self.folder / "commands.jsonl")}

    async def after_connect(self, driver: ServoDriver, count: int) -> None:
        self.before = count  # connecting starts a new session in the same file

    def expected(self, positions: Mapping[str, float]) -> Any:
        return {name: pytest.approx(value, abs=5e-4) for name, value in positions.items()}

    async def observed(self, count: int) -> Any:
        lines = read_record(self.folder / "commands.jsonl", session=-1)
        assert len(lines) == count - self.before
        return lines[-1].servos  # rounded to 0.001 µs

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        return [({"driver": "record"}, "missing required field `out`")]


class VirtualRig(DriverRig):
    """The live face page, read through its WebSocket as a browser would."""

    profile = VIRTUAL

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.faces: list[dict[str, Any]] = []
        self._session: aiohttp.ClientSession | None = None
        self._task: asyncio.Task[None] | None = None

    def config(self) -> dict[str, Any]:
        return {"driver": "virtual", "http": "127.0.0.1:0"}

    def expected(self, positions: Mapping[str, float]) -> Any:
        return {name: round(value, 2) for name, value in positions.items()}

    async def after_connect(self, driver: ServoDriver, count: int) -> None:
        assert isinstance(driver, VirtualDriver)
        await self.aclose()  # a page of an earlier connection
        self.faces = []
        self._session = aiohttp.ClientSession()
        ws = await self._session.ws_connect(driver.url + "ws")
        self._task = asyncio.create_task(self._read(ws))
        await asyncio.sleep(0.1)

    async def _read(self, ws: aiohttp.ClientWebSocketResponse) -> None:
        async for msg in ws:
            if msg.type == aiohttp.WSMsgType.TEXT and json.loads(msg.data)["type"] == "face":
                self.faces.append(json.loads(msg.data))

    async def observed(self, count: int) -> Any:
        """The newest face once it is command ``count`` (a page may skip older ones)."""
        for _ in range(300):
            if self.faces and self.faces[-1]["seq"] in (count, None):
                break
            await asyncio.sleep(0.01)
        return self.faces[-1]["controls"] if self.faces else None

    async def aclose(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        if self._session is not None:
            await self._session.close()
            self._session = None

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        return [
            ({"driver": "virtual", "http": "8080"}, "--http: expected HOST:PORT"),
            ({"driver": "virtual", "max_clients": 0}, "Expected `int` >= 1"),
        ]


class VmcRig(DriverRig):
    """A real OSC server (python-osc) receiving the VMC messages."""

    profile = VIRTUAL

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self._receiver_context = osc_receiver()
        self.receiver: Receiver = self._receiver_context.__enter__()
        self.mapping = AvatarMapping(self.profile)

    def config(self) -> dict[str, Any]:
        return {"driver": "vmc", "port": self.receiver.port}

    def expected(self, positions: Mapping[str, float]) -> Any:
        return self.mapping.blendshapes(positions)

    async def observed(self, count: int) -> Any:
        await asyncio.to_thread(self.receiver.wait_for, "/VMC/Ext/Blend/Apply", count)
        return {k: pytest.approx(v, abs=1e-6) for k, v in self.receiver.blendshapes().items()}

    async def aclose(self) -> None:
        self._receiver_context.__exit__(None, None, None)

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        return [
            ({"driver": "vmc", "port": 0}, "Expected `int` >= 1"),
            ({"driver": "vmc", "host": "no.such.invalid"}, "--vmc-host: cannot resolve"),
        ]


class MaestroRig(DriverRig):
    can_unplug = has_device_path = True
    tolerance_us = 0.125  # quarter-µs targets

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.device = FakeMaestro(folder / "ttyMaestro", channels=24)
        self.device.plug()

    def config(self) -> dict[str, Any]:
        return {"driver": "maestro", "port": str(self.device.link), "model": "mini24"}

    async def observed(self, count: int) -> Any:
        with self.device.lock:
            targets = list(self.device.targets)
        return {s.name: targets[s.channel] / 4 for s in self.profile.servos if targets[s.channel]}

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

    async def aclose(self) -> None:
        self.device.close()


class SSC32Rig(DriverRig):
    can_unplug = has_device_path = True

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.device = FakeSSC32(folder / "ttySSC32")
        self.device.plug()

    def config(self) -> dict[str, Any]:
        return {"driver": "ssc32", "port": str(self.device.link)}

    async def observed(self, count: int) -> Any:
        with self.device.lock:
            widths = dict(self.device.widths)
        return {
            s.name: float(widths[s.channel]) for s in self.profile.servos if s.channel in widths
        }

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        port = str(self.device.link)
        return [
            ({"driver": "ssc32", "port": port, "move_time_ms": 0}, "Expected `int` >= 1"),
            ({"driver": "ssc32", "port": ""}, "the port is empty"),
        ]

    def unplug(self) -> None:
        self.device.unplug()

    def plug(self) -> None:
        self.device.plug()

    async def aclose(self) -> None:
        self.device.close()


class ArduinoRig(DriverRig):
    can_unplug = has_device_path = needs_firmware = True
    tolerance_us = TICK_US / 2 + 0.52  # integer µs, then a PCA9685 step

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.uno = UnoRig(folder / "uno", cable=True)

    def config(self) -> dict[str, Any]:
        return {"driver": "arduino", "port": str(self.uno.port), "board_watchdog_ms": 60000}

    async def observed(self, count: int) -> Any:
        widths = self.uno.widths()
        return {s.name: widths[s.channel] for s in self.profile.servos if s.channel in widths}

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

    async def aclose(self) -> None:
        self.uno.close()


class PCA9685Rig(DriverRig):
    """The register-exact PCA9685 model behind smbus2's interface (fake_devices/pca9685.py),
    read back as the pulse widths its registers make."""

    can_unplug = has_device_path = True
    tolerance_us = 122 / 25e6 * 1e6 + 1e-6  # one tick, (121 + 1) / 25 MHz (limits round inward)

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.chip = FakePCA9685()
        self.adapter = FakeI2CAdapter(folder / "i2c-1", self.chip)

    def config(self) -> dict[str, Any]:
        return {"driver": "pca9685", "bus": str(self.adapter.path), "exit_hold_s": 0.01}

    def make(self) -> ServoDriver:
        config = DRIVERS.parse(self.config())
        assert isinstance(config, PCA9685Config)
        return PCA9685Driver(config, self.profile, open_bus=self.adapter.open)

    async def observed(self, count: int) -> Any:
        assert not self.chip.violations, self.chip.violations
        widths = self.chip.widths_us()
        return {s.name: widths[s.channel] for s in self.profile.servos if s.channel in widths}

    def missing_device(self) -> dict[str, Any]:
        return {**self.config(), "bus": str(self.folder / "no-such-port")}

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        bus = str(self.adapter.path)
        return [
            ({"driver": "pca9685", "bus": bus, "address": "0x80"}, "outside the 7-bit"),
            ({"driver": "pca9685", "bus": bus, "address": "forty"}, "such as 0x40, got 'forty'"),
            ({"driver": "pca9685", "bus": bus, "frequency_hz": 10}, "PRE_SCALE 609, outside"),
            ({"driver": "pca9685", "bus": bus, "frequency_hz": 1000}, "outside what the PCA9685"),
            ({"driver": "pca9685", "bus": ""}, "--i2c-bus: the bus is empty"),
            ({"driver": "pca9685", "bus": bus, "oscillator_hz": 0}, "Expected `float` > 0.0"),
        ]

    def unplug(self) -> None:
        self.adapter.unplug()

    def plug(self) -> None:
        self.adapter.plug()


class DynamixelRig(DriverRig):
    """An emulated Protocol 2.0 bus of 16 XL430-W250 (fake_devices/dynamixel.py), ids 1..16,
    read back as the goal positions the servos hold, in µs (0.09° per µs, 1500 = centre)."""

    can_unplug = has_device_path = True
    tolerance_us = 0.5 / 1.024 + 1e-6  # half a native step (4096 per turn)

    def __init__(self, folder: Path) -> None:
        super().__init__(folder)
        self.device = FakeDynamixelBus(folder / "ttyDXL", list(range(1, 17)))
        self.device.plug()

    def config(self) -> dict[str, Any]:
        return {
            "driver": "dynamixel",
            "port": str(self.device.link),
            "baud": 1000000,
        }

    async def observed(self, count: int) -> Any:
        goals = self.device.goals()
        torque = self.device.torque()
        return {
            s.name: 1500 + (goals[s.channel + 1] - 2048) / 1.024
            for s in self.profile.servos
            if torque[s.channel + 1]
        }

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        port = str(self.device.link)
        return [
            ({"driver": "dynamixel"}, "missing required field `port`"),
            ({"driver": "dynamixel", "port": ""}, "the port is empty"),
            ({"driver": "dynamixel", "port": port, "protocol": 3}, "Invalid enum value 3"),
            ({"driver": "dynamixel", "port": port, "at_exit": "limp"}, "Expected `str` matching"),
            ({"driver": "dynamixel", "port": port, "read_budget_ms": 0}, "Expected `float` > 0"),
            ({"driver": "dynamixel", "port": port, "baud": 0}, "Expected `int` >= 1"),
        ]

    def unplug(self) -> None:
        self.device.unplug()

    def plug(self) -> None:
        self.device.plug()

    async def aclose(self) -> None:
        self.device.close()


class FeetechRig(DynamixelRig):
    """An emulated bus of 16 STS3215 (fake_devices/feetech.py), ids 1..16, read back as the
    goal positions the servos hold, in µs (4096 per turn too)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.device = FakeFeetechBus(folder / "ttySTS", list(range(1, 17)))  # type: ignore[assignment]
        self.device.plug()

    def config(self) -> dict[str, Any]:
        return {"driver": "feetech", "port": str(self.device.link)}

    def bad_configs(self) -> list[tuple[dict[str, Any], str]]:
        port = str(self.device.link)
        return [
            ({"driver": "feetech"}, "missing required field `port`"),
            ({"driver": "feetech", "port": "ftp://a:1"}, "unknown URL scheme 'ftp'"),
            ({"driver": "feetech", "port": port, "at_exit": "limp"}, "Expected `str` matching"),
            ({"driver": "feetech", "port": port, "latency_ms": -1}, "Expected `float` >= 0"),
        ]


#: Drivers whose rig runs the contract in a test group of its own, and where: the ros2 driver
#: needs rclpy and a network namespace with only loopback (``make test-ros2``).
ELSEWHERE: dict[str, str] = {"ros2": "tests/ros2/test_ros2_contract.py"}

#: Driver name -> its rig.
RIGS: dict[str, type[DriverRig]] = {
    "record": RecordRig,
    "virtual": VirtualRig,
    "vmc": VmcRig,
    "maestro": MaestroRig,
    "ssc32": SSC32Rig,
    "arduino": ArduinoRig,
    "dynamixel": DynamixelRig,
    "feetech": FeetechRig,
    "pca9685": PCA9685Rig,
}
