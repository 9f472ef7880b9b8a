"""The control service with drivers that fail or lose their board: it never stops, counts the
failures, and says in its stats what the board's link is doing."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Mapping

import msgspec
from fake_devices.ssc32 import FakeSSC32
from waiting import eventually

from facesynth.runtime import codec, keys
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.service import ServiceContext, run_service
from facesynth.schemas.messages import ServiceStats, ServoCommands
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverError, ServoDriver
from facesynth.services.control.drivers.ssc32 import SSC32Config, SSC32Driver
from facesynth.services.control.service import ControlService

RIG = "drv"


class FlakyDriver(ServoDriver):
    """Fails every other send (a test double at the driver seam)."""

    def __init__(self) -> None:
        self.sent: list[dict[str, float]] = []
        self.calls = 0

    async def connect(self) -> None:
        pass

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        self.calls += 1
        if self.calls % 2 == 0:
            raise DriverError("the board said no")
        self.sent.append(dict(positions))

    async def close(self) -> None:
        pass


#: paper16 without speed limits or catch-up, so each command applies at once.
UNLIMITED = msgspec.structs.replace(
    load_profile("paper16"),
    neutral_ramp_s=0.0,
    servos=[
        msgspec.structs.replace(spec, max_speed=0.0, max_accel=0.0)
        for spec in load_profile("paper16").servos
    ],
)


def commands(seq: int, **positions: float) -> bytes:
    return codec.encode(
        ServoCommands(
            seq=seq, t_capture_ns=1, t_media_ns=1, face=True, profile="paper16", positions=positions
        )
    )


async def test_driver_errors_are_counted_and_the_service_goes_on() -> None:
    network = MemoryNetwork()
    bus = network.bus()
    driver = FlakyDriver()
    control = ControlService(UNLIMITED, driver, watchdog_s=5)  # commands apply at once
    ctx = ServiceContext(bus, RIG, "control")
    task = asyncio.create_task(run_service(ctx, control.serve))
    try:
        await eventually(lambda: bool(network.tokens))
        key = keys.stage_key(RIG, "servo_commands")
        for seq in range(6):
            bus.publish(key, commands(seq, jaw=1500.0 + 10 * seq))
        await eventually(lambda: control.last_frame == 5)
        assert control.driver_errors == 3 and not task.done()  # calls 2, 4, 6 (call 1: neutral)
        assert [p["jaw"] for p in driver.sent[1:]] == [1510.0, 1530.0, 1550.0]
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


async def test_an_unplugged_board_shows_in_the_stats_and_comes_back(ssc32: FakeSSC32) -> None:
    network = MemoryNetwork()
    bus = network.bus()
    stats = bus.subscribe_queued(keys.stats_pattern(RIG), 64)
    profile = load_profile("paper16")
    control = ControlService(
        profile, SSC32Driver(SSC32Config(port=str(ssc32.link)), profile), watchdog_s=5
    )
    ctx = ServiceContext(bus, RIG, "control", stats_interval=0.05)
    task = asyncio.create_task(run_service(ctx, control.serve))

    async def next_note() -> str:
        sample = await asyncio.wait_for(stats.receive(), 2)
        return codec.decode(sample.payload, ServiceStats).note

    try:
        await eventually(lambda: bool(network.tokens))
        key = keys.stage_key(RIG, "servo_commands")
        bus.publish(key, commands(0, jaw=1800.0))
        await ssc32.until(lambda: ssc32.widths.get(11) == 1800)
        assert "connected to" in await next_note()
        ssc32.unplug()
        bus.publish(key, commands(1, jaw=1700.0))
        await eventually(lambda: control.last_frame == 1)
        for _ in range(40):
            if "disconnected" in await next_note():
                break
        else:
            raise AssertionError("the stats never said the board is disconnected")
        ssc32.plug()
        bus.publish(key, commands(2, jaw=1600.0))
        await ssc32.until(lambda: ssc32.widths.get(11) in (1600, 1700), timeout=5)
        bus.publish(key, commands(3, jaw=1650.0))
        await ssc32.until(lambda: ssc32.widths.get(11) == 1650, timeout=5)
        assert not task.done() and control.driver_errors == 0
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
    ssc32.wait_for(lambda: ssc32.widths[11] == 1500)  # neutral on shutdown
