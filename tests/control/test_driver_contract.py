"""One contract, every servo driver: record, virtual (live page) and vmc (avatar over OSC).

Each harness builds its driver on the ``virtual`` profile and reads back what reached the
outside world (the file, a page's WebSocket, a real OSC server), in the driver's own form.
"""

from __future__ import annotations

import abc
import asyncio
import contextlib
import json
from collections.abc import AsyncIterator, Mapping
from pathlib import Path
from typing import Any

import aiohttp
import pytest

from facesynth.runtime.plugins import PluginError
from facesynth.runtime.profiles import Profile, load_profile
from services.control.core import CommandInfo
from services.control.drivers.base import DriverError, ServoDriver
from services.control.drivers.record import RecordConfig, RecordDriver, read_record
from services.control.drivers.registry import DRIVERS
from services.control.drivers.virtual import VirtualConfig, VirtualDriver
from services.control.drivers.vmc import AvatarMapping, VmcConfig, VmcDriver
from tests.control.osc_receiver import osc_receiver

PROFILE = load_profile("virtual")


class Harness(abc.ABC):
    """A driver and a way to see what it put out."""

    driver: ServoDriver

    def expected(self, positions: Mapping[str, float]) -> Any:
        """What the outside should see for ``positions``."""
        return {name: round(value, 2) for name, value in positions.items()}

    @abc.abstractmethod
    async def observed(self, count: int) -> Any:
        """What the outside saw last, once ``count`` commands have arrived."""

    async def after_connect(self) -> None:  # noqa: B027 - optional
        """Attach the observer once the driver is up."""

    async def aclose(self) -> None:  # noqa: B027 - optional
        """Release the observer."""


class RecordHarness(Harness):
    def __init__(self, tmp_path: Path) -> None:
        self.path = tmp_path / "commands.jsonl"
        self.driver = RecordDriver(RecordConfig(out=str(self.path)), PROFILE)

    async def observed(self, count: int) -> Any:
        lines = read_record(self.path)
        assert len(lines) == count
        return {name: round(value, 2) for name, value in lines[-1].servos.items()}


class VirtualHarness(Harness):
    def __init__(self, tmp_path: Path) -> None:
        self.driver = VirtualDriver(VirtualConfig(http="127.0.0.1:0"), PROFILE)
        self.faces: list[dict[str, Any]] = []
        self._session: aiohttp.ClientSession | None = None
        self._task: asyncio.Task[None] | None = None

    async def after_connect(self) -> None:
        assert isinstance(self.driver, VirtualDriver)
        self._session = aiohttp.ClientSession()
        ws = await self._session.ws_connect(self.driver.url + "ws")
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
        return self.faces[-1]["controls"]

    async def aclose(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        if self._session is not None:
            await self._session.close()


class VmcHarness(Harness):
    def __init__(self, tmp_path: Path, port: int, receiver: Any) -> None:
        self.driver = VmcDriver(VmcConfig(port=port), PROFILE)
        self.receiver = receiver
        self.mapping = AvatarMapping(PROFILE)

    def expected(self, positions: Mapping[str, float]) -> Any:
        return self.mapping.blendshapes(positions)

    async def observed(self, count: int) -> Any:
        await asyncio.to_thread(self.receiver.wait_for, "/VMC/Ext/Blend/Apply", count)
        return {k: pytest.approx(v, abs=1e-6) for k, v in self.receiver.blendshapes().items()}


@pytest.fixture(params=["record", "virtual", "vmc"])
async def harness(request: pytest.FixtureRequest, tmp_path: Path) -> AsyncIterator[Harness]:
    with osc_receiver() as receiver:
        made: Harness
        if request.param == "record":
            made = RecordHarness(tmp_path)
        elif request.param == "virtual":
            made = VirtualHarness(tmp_path)
        else:
            made = VmcHarness(tmp_path, receiver.port, receiver)
        try:
            yield made
        finally:
            await made.driver.close()
            await made.aclose()


def positions(**controls: float) -> dict[str, float]:
    return {**PROFILE.neutral_positions(), **controls}


async def _start(harness: Harness) -> None:
    await harness.driver.connect()
    await harness.after_connect()


class _Counted:
    """Numbers each send, so a harness knows which command it is looking at."""

    def __init__(self, harness: Harness) -> None:
        self.harness = harness
        self.count = 0

    async def send(self, values: dict[str, float]) -> Any:
        self.count += 1
        await self.harness.driver.send(values, CommandInfo(self.count, None, True))
        return await self._observe()

    async def neutral(self) -> Any:
        self.count += 1
        await self.harness.driver.neutral(PROFILE.neutral_positions())
        return await self._observe()

    async def _observe(self) -> Any:
        return await self.harness.observed(self.count)


async def test_what_is_sent_is_what_comes_out(harness: Harness) -> None:
    await _start(harness)
    counted = _Counted(harness)
    values = positions(jaw=640.0, lid_left=120.0, brow_right=910.0)
    assert await counted.send(values) == harness.expected(values)


async def test_neutral_puts_out_the_neutral_face(harness: Harness) -> None:
    await _start(harness)
    counted = _Counted(harness)
    await counted.send(positions(jaw=1000.0))
    assert await counted.neutral() == harness.expected(PROFILE.neutral_positions())


async def test_limits_come_out_as_limits(harness: Harness) -> None:
    """Positions arrive clamped; a driver passes the profile's extremes through unchanged."""
    await _start(harness)
    counted = _Counted(harness)
    low = {spec.name: spec.min_us for spec in PROFILE.servos}
    high = {spec.name: spec.max_us for spec in PROFILE.servos}
    assert await counted.send(low) == harness.expected(low)
    assert await counted.send(high) == harness.expected(high)


async def test_the_last_of_many_commands_is_what_stays(harness: Harness) -> None:
    await _start(harness)
    counted = _Counted(harness)
    for i in range(30):
        await harness.driver.send(positions(jaw=i * 30.0), CommandInfo(i + 1, None, True))
    counted.count = 30
    assert await counted._observe() == harness.expected(positions(jaw=29 * 30.0))


async def test_send_before_connect_and_after_close_is_a_driver_error(harness: Harness) -> None:
    with pytest.raises(DriverError):
        await harness.driver.send(positions(), CommandInfo(1, None, True))
    await _start(harness)
    await harness.driver.close()
    await harness.driver.close()  # twice is harmless
    with pytest.raises(DriverError):
        await harness.driver.send(positions(), CommandInfo(2, None, True))


async def test_close_without_connect_is_harmless(harness: Harness) -> None:
    await harness.driver.close()


@pytest.mark.parametrize("name", ["record", "virtual", "vmc"])
def test_malformed_settings_are_refused_naming_the_field(name: str) -> None:
    with pytest.raises(PluginError, match="unknown field `nope`"):
        DRIVERS.parse(
            {"driver": name, **({"out": "x.jsonl"} if name == "record" else {}), "nope": 1}
        )


def test_every_driver_is_in_this_contract() -> None:
    assert set(DRIVERS.names()) == {"record", "virtual", "vmc"}
    assert isinstance(PROFILE, Profile)
