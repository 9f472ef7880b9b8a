"""The feetech driver against an emulated bus (fake_devices/feetech.py) on a pty: speeds,
read-back, an overloaded servo held while the others go on, garbled status packets, a wrong
model, and SCS servos (high byte first, one READ each)."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import msgspec
import pytest
from fake_devices.feetech import FakeFeetechBus
from waiting import eventually

from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverConfigError
from facesynth.services.control.drivers.feetech import FeetechDriver
from facesynth.services.control.drivers.registry import DRIVERS

PAPER16 = load_profile("paper16")
IDS = list(range(1, 17))


def profile(**servo_fields: Any) -> Profile:
    servos = [msgspec.structs.replace(s, **servo_fields) for s in PAPER16.servos]
    return msgspec.structs.replace(PAPER16, servos=servos)


def driver(bus: FakeFeetechBus, prof: Profile = PAPER16) -> FeetechDriver:
    config = {"driver": "feetech", "port": str(bus.link)}
    made = DRIVERS.build(DRIVERS.parse(config), prof)
    assert isinstance(made, FeetechDriver)
    return made


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[FakeFeetechBus]:
    device = FakeFeetechBus(tmp_path / "ttySTS", IDS)
    device.plug()
    yield device
    device.close()


@pytest.fixture
async def connected(bus: FakeFeetechBus) -> AsyncIterator[FeetechDriver]:
    made = driver(bus)
    await made.connect()
    try:
        yield made
    finally:
        await made.close()


async def send(made: FeetechDriver, positions: dict[str, float]) -> None:
    await made.send(positions, CommandInfo(None, None, True))


async def test_speed_acceleration_and_torque(connected: FeetechDriver, bus: FakeFeetechBus) -> None:
    jaw = bus.servos[PAPER16.servo("jaw").channel + 1]
    assert jaw.get(46, 2) == 2560  # 2500 µs/s x 1.024 steps/µs, in steps/s
    assert jaw.get(41, 1) == 254  # 30000 µs/s² = 307 x 100 steps/s²: the register's most
    assert all(bus.torque().values())


async def test_read_back_and_an_overload_held(
    connected: FeetechDriver, bus: FakeFeetechBus, caplog: pytest.LogCaptureFixture
) -> None:
    wanted = {s.name: s.max_us for s in PAPER16.servos}
    await send(connected, wanted)
    await eventually(
        lambda: (
            len(connected.readings()) == 16
            and all(abs(connected.readings()[n].position_us - us) < 1 for n, us in wanted.items())
        )
    )
    jaw = PAPER16.servo("jaw")
    stalled = bus.servos[jaw.channel + 1]
    stalled.stall_at = 2048
    await send(connected, {"jaw": jaw.min_us})
    await eventually(lambda: connected.readings()["jaw"].fault == "overload")

    def said() -> int:
        return len([r for r in caplog.records if "overload; holding it" in r.getMessage()])

    # The worker logs after it records the fault (outside its lock): wait for the line too.
    await eventually(lambda: said() >= 1)
    assert said() == 1
    held = stalled.goal
    await send(connected, {s.name: s.min_us for s in PAPER16.servos})
    want = {s.channel + 1: 2048 - 512 for s in PAPER16.servos}
    await eventually(lambda: all(bus.goals()[i] == want[i] for i in IDS if i != jaw.channel + 1))
    assert stalled.goal == held


async def test_garbled_status_packets_are_dropped(
    connected: FeetechDriver, bus: FakeFeetechBus
) -> None:
    bus.garble(40)
    await eventually(lambda: bus.garbled == 0)
    worker = connected.worker
    assert worker is not None and worker.bus.garbled > 0  # type: ignore[attr-defined]
    for reading in connected.readings().values():
        assert math.isnan(reading.position_us) or 1000 <= reading.position_us <= 2000


async def test_a_wrong_model_is_refused(bus: FakeFeetechBus) -> None:
    with pytest.raises(DriverConfigError, match=r"is a STS3215 \(model number 777\), but"):
        await driver(bus, profile(model="SCS0009")).connect()


async def test_scs_servos_take_high_byte_first(tmp_path: Path) -> None:
    device = FakeFeetechBus(tmp_path / "ttySCS", IDS, model="SCS0009")
    device.plug()
    made = driver(device, profile(model="SCS0009"))
    try:
        await made.connect()
        await send(made, {s.name: s.max_us for s in PAPER16.servos})
        unit = 0.09 * 1024 / 300  # 1024 positions over 300°; limits rounded inward
        want = {s.channel + 1: math.floor(512 + (s.max_us - 1500) * unit) for s in PAPER16.servos}
        await eventually(lambda: device.goals() == want)
        await eventually(lambda: len(made.readings()) == 16)
        assert device.servos[1].table[42:44] == want[1].to_bytes(2, "big")
    finally:
        await made.close()
        device.close()
