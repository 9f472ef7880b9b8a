"""The dynamixel driver against an emulated bus (fake_devices/dynamixel.py) on a pty: model
checks, speed settings, read-back, a servo that stalls or stops answering, garbled status
packets, shutdown, and Protocol 1.0 (AX-12A)."""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import msgspec
import pytest
from fake_devices.dynamixel import FakeDynamixelBus
from waiting import eventually

from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverConfigError
from facesynth.services.control.drivers.dynamixel import DynamixelDriver
from facesynth.services.control.drivers.registry import DRIVERS

PAPER16 = load_profile("paper16")
IDS = list(range(1, 17))


def profile(**servo_fields: Any) -> Profile:
    """paper16 with ``servo_fields`` set on every servo."""
    servos = [msgspec.structs.replace(s, **servo_fields) for s in PAPER16.servos]
    return msgspec.structs.replace(PAPER16, servos=servos)


def driver(bus: FakeDynamixelBus, prof: Profile = PAPER16, **options: Any) -> DynamixelDriver:
    config = {"driver": "dynamixel", "port": str(bus.link), "baud": 1000000}
    made = DRIVERS.build(DRIVERS.parse({**config, **options}), prof)
    assert isinstance(made, DynamixelDriver)
    return made


@pytest.fixture
def bus(tmp_path: Path) -> Any:
    device = FakeDynamixelBus(tmp_path / "ttyDXL", IDS)
    device.plug()
    yield device
    device.close()


@pytest.fixture
async def connected(bus: FakeDynamixelBus) -> AsyncIterator[DynamixelDriver]:
    made = driver(bus)
    await made.connect()
    try:
        yield made
    finally:
        await made.close()


async def send(made: DynamixelDriver, positions: dict[str, float]) -> None:
    await made.send(positions, CommandInfo(None, None, True))


async def test_speeds_and_torque_come_from_the_profile(
    connected: DynamixelDriver, bus: FakeDynamixelBus
) -> None:
    jaw = PAPER16.servo("jaw")  # 2500 µs/s, 30000 µs/s²
    servo = bus.servos[jaw.channel + 1]
    # 2500 µs/s x 1.024 units/µs = 2560 units/s; / (0.229 rev/min = 15.63 units/s) = 164
    assert servo.get(112, 4) == round(2500 * 1.024 / (0.229 / 60 * 4096))
    assert servo.get(108, 4) == round(30000 * 1.024 / (214.577 / 3600 * 4096))
    assert all(bus.torque().values())


async def test_read_back_arrives_in_microseconds(
    connected: DynamixelDriver, bus: FakeDynamixelBus
) -> None:
    wanted = {s.name: s.max_us for s in PAPER16.servos}
    await send(connected, wanted)

    def settled() -> bool:
        got = connected.readings()
        return len(got) == 16 and all(abs(got[n].position_us - us) < 1 for n, us in wanted.items())

    await eventually(settled)
    reading = connected.readings()["jaw"]
    assert reading.temperature_c == 32.0 and reading.fault == ""


async def test_a_stalled_servo_is_held_and_the_others_go_on(
    connected: DynamixelDriver, bus: FakeDynamixelBus, caplog: pytest.LogCaptureFixture
) -> None:
    jaw = PAPER16.servo("jaw")
    stalled = bus.servos[jaw.channel + 1]
    stalled.stall_at = 2048 + 100  # the skin blocks it ~98 µs past the centre
    await send(connected, {"jaw": jaw.max_us})
    await eventually(
        lambda: (
            connected.readings().get("jaw", None) is not None
            and connected.readings()["jaw"].fault == "overload"
        )
    )
    assert abs(connected.readings()["jaw"].position_us - (1500 + 100 / 1.024)) < 1
    # The worker logs after it records the fault (outside its lock): wait for the line too.
    await eventually(lambda: any("overload" in r.getMessage() for r in caplog.records))
    lines = [r for r in caplog.records if "overload" in r.getMessage()]
    assert len(lines) == 1 and "holding it" in lines[0].getMessage()
    held_goal = stalled.goal
    others = {s.name: s.min_us for s in PAPER16.servos if s.name != "jaw"}
    await send(connected, {**others, "jaw": jaw.min_us})
    goals = {s.name: s.channel + 1 for s in PAPER16.servos}
    await eventually(
        lambda: all(
            bus.goals()[goals[n]] == 2048 - round((1500 - us) * 1.024) for n, us in others.items()
        )
    )
    await asyncio.sleep(0.2)
    assert stalled.goal == held_goal  # held: its goal is no longer written
    assert "faults: id 12 overload" in connected.state()


async def test_a_servo_that_stops_answering_shows_and_the_others_go_on(
    connected: DynamixelDriver, bus: FakeDynamixelBus
) -> None:
    bus.servos[5].silent = True
    name = next(s.name for s in PAPER16.servos if s.channel == 4)
    await eventually(
        lambda: (
            connected.readings().get(name) is not None
            and connected.readings()[name].fault == "not answering"
        ),
        timeout=8,
    )
    wanted = {s.name: s.max_us for s in PAPER16.servos}
    await send(connected, wanted)
    want = {s.channel + 1: 2048 + round((s.max_us - 1500) * 1.024) for s in PAPER16.servos}
    await eventually(lambda: all(bus.goals()[i] == want[i] for i in IDS if i != 5))
    assert "disconnected" not in connected.state()
    bus.servos[5].silent = False
    await eventually(lambda: connected.readings()[name].fault == "", timeout=8)


async def test_garbled_status_packets_are_dropped_not_read(
    connected: DynamixelDriver, bus: FakeDynamixelBus
) -> None:
    await send(connected, {s.name: s.max_us for s in PAPER16.servos})
    await asyncio.sleep(0.3)
    bus.garble(40)
    await eventually(lambda: bus.garbled == 0)
    worker = connected.worker
    assert worker is not None and worker.bus.garbled > 0  # type: ignore[attr-defined]
    for reading in connected.readings().values():  # never a position from a bad packet
        assert math.isnan(reading.position_us) or 1000 <= reading.position_us <= 2000
    assert "disconnected" not in connected.state()


async def test_a_wrong_model_is_refused_at_start(bus: FakeDynamixelBus) -> None:
    made = driver(bus, profile(model="XM430-W350"))
    with pytest.raises(DriverConfigError) as info:
        await made.connect()
    assert str(info.value) == (
        "servo 'right_eyebrow' (id 1) is a XL430-W250 (model number 1060), but profile "
        "'paper16' expects a XM430-W350"
    )


async def test_a_missing_servo_is_refused_at_start(tmp_path: Path) -> None:
    device = FakeDynamixelBus(tmp_path / "ttyDXL", IDS[:-1])
    device.plug()
    try:
        with pytest.raises(DriverConfigError, match=r"servo 'left_lower_lip' \(id 16\) does not"):
            await driver(device).connect()
    finally:
        device.close()


async def test_limits_beyond_the_servo_are_refused(bus: FakeDynamixelBus) -> None:
    made = driver(bus, profile(native_min=-10, native_max=3000))
    with pytest.raises(DriverConfigError, match=r"outside the XL430-W250's 0\.\.4095"):
        await made.connect_once()


async def test_shutdown_holds_the_neutral_face_by_default(bus: FakeDynamixelBus) -> None:
    made = driver(bus)
    await made.connect()
    await send(made, {s.name: s.max_us for s in PAPER16.servos})
    await made.neutral(PAPER16.neutral_positions())
    await made.close()
    neutral = {s.channel + 1: 2048 + round((s.neutral_us - 1500) * 1.024) for s in PAPER16.servos}
    # Written before the port closed; the emulator (a thread reading the pty) may lag under load.
    await eventually(lambda: bus.goals() == neutral)
    assert all(bus.torque().values())


async def test_shutdown_can_relax(bus: FakeDynamixelBus) -> None:
    made = driver(bus, at_exit="relax")
    await made.connect()
    await made.neutral(PAPER16.neutral_positions())
    await made.close()
    await eventually(lambda: not any(bus.torque().values()))


async def test_protocol_one_drives_ax12(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO)
    device = FakeDynamixelBus(tmp_path / "ttyAX", IDS, model="AX-12A", protocol=1)
    device.plug()
    made = driver(device, profile(model="AX-12A"))
    try:
        await made.connect()
        assert made.protocol == 1
        await send(made, {s.name: s.min_us for s in PAPER16.servos})
        # 0.09°/µs on 1024 positions over 300°: 0.307 units per µs; limits rounded inward
        unit = 0.09 * 1024 / 300
        want = {s.channel + 1: math.ceil(512 + (s.min_us - 1500) * unit) for s in PAPER16.servos}
        await eventually(lambda: device.goals() == want)
        await eventually(lambda: len(made.readings()) == 16)
        jaw = PAPER16.servo("jaw")
        top = math.floor(512 + (jaw.max_us - 1500) * unit)
        device.servos[12].stall_at = (want[12] + top) // 2  # blocked: status says overload
        await send(made, {"jaw": jaw.max_us})
        await eventually(lambda: made.readings()["jaw"].fault == "overload")
        await eventually(lambda: "overload; holding it" in caplog.text)  # logged just after
    finally:
        await made.close()
        device.close()


async def test_a_bus_where_no_servo_answers_is_reopened(
    connected: DynamixelDriver, bus: FakeDynamixelBus, caplog: pytest.LogCaptureFixture
) -> None:
    for servo in bus.servos.values():
        servo.silent = True
    await eventually(lambda: "disconnected" in connected.state(), timeout=8)
    assert any("bus lost (no servo answered for 2 s)" in r.getMessage() for r in caplog.records)
    for servo in bus.servos.values():
        servo.silent = False
    await eventually(lambda: "reconnected 1x" in connected.state(), timeout=8)
    await send(connected, {s.name: s.min_us for s in PAPER16.servos})
    await eventually(lambda: bus.goals()[12] == 2048 - 512)


def test_control_status_reads_the_bus_and_moves_nothing(
    bus: FakeDynamixelBus, capsys: pytest.CaptureFixture[str]
) -> None:
    from facesynth.app.cli import main

    argv = ["control", "status", "--driver", "dynamixel", "--port", str(bus.link), "--baud",
            "1000000"]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "'id': 12, 'model': 'XL430-W250', 'position_us': 1500.0" in out
    assert [p for p in bus.packets if p[1] in (0x03, 0x83)] == []  # no WRITE, no SYNC WRITE
    assert not any(bus.torque().values())


async def test_read_backs_follow_writes_at_their_own_rate(bus: FakeDynamixelBus) -> None:
    """30 poses a second with ``--bus-read-hz 10``: every pose is one Sync Write, and a Sync
    Read follows about every third (never two between writes: one frame's bus time)."""
    made = driver(bus, read_hz=10)
    await made.connect()
    try:
        with bus.lock:
            bus.packets.clear()
        for frame in range(60):
            pose = {s.name: s.neutral_us + (frame % 7) for s in PAPER16.servos}
            await send(made, pose)
            await asyncio.sleep(1 / 30)
        with bus.lock:
            kinds = [packet[1] for packet in bus.packets]
    finally:
        await made.close()
    writes, reads = kinds.count(0x83), kinds.count(0x82)
    assert writes >= 59 and 13 <= reads <= 24, (writes, reads)  # 2 s: about 20 read-backs
    between = "".join("w" if k == 0x83 else "r" for k in kinds if k in (0x82, 0x83))
    assert "rr" not in between


def test_read_back_rates_by_protocol() -> None:
    """One Sync Read for every servo: 15 a second; one READ per servo (1.0): 5."""
    import dynamixel_sdk

    from facesynth.services.control.drivers.dynamixel.bus import DynamixelBus

    x = DynamixelBus(dynamixel_sdk, "/dev/null", 1000000, protocol=2, latency_ms=0)
    ax = DynamixelBus(dynamixel_sdk, "/dev/null", 1000000, protocol=1, latency_ms=0)
    assert (x.read_hz(IDS), ax.read_hz(IDS)) == (15.0, 5.0)
