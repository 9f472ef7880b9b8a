"""The ``maestro`` driver against a fake Maestro on a pty: commands per model, speed limits,
errors, a Maestro that stops answering."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from fake_devices.maestro import PROTOCOL_ERROR, FakeMaestro
from profile_files import write_profile

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverConfigError
from facesynth.services.control.drivers.maestro import MaestroConfig, MaestroDriver
from facesynth.services.control.drivers.maestro import driver as maestro_driver
from facesynth.services.control.drivers.maestro import protocol as mp

INFO = CommandInfo(frame=1, t_capture_ns=None, face=True)


def commands_of(device: FakeMaestro, code: int) -> list[tuple[int, ...]]:
    with device.lock:
        return [c for c in device.commands if c[0] == code]


@pytest.mark.parametrize(
    ("model", "code", "count"),
    [("mini24", mp.SET_MULTIPLE_TARGETS, 1), ("auto", mp.SET_TARGET, 16)],
)
async def test_the_model_decides_the_command(
    maestro: FakeMaestro, model: str, code: int, count: int
) -> None:
    profile = load_profile("paper16")
    driver = MaestroDriver(MaestroConfig(port=str(maestro.link), model=model), profile)  # type: ignore[arg-type]
    await driver.connect()
    try:
        await maestro.until(lambda: maestro.targets[15] == 6000)  # the pose written on connect
        with maestro.lock:
            maestro.commands.clear()
        await driver.send({s.name: 1000.0 + 50 * s.channel + 0.3 for s in profile.servos}, INFO)
        await maestro.until(lambda: maestro.targets[15] == round((1750 + 0.3) * 4))
        assert len(commands_of(maestro, code)) == count
        assert maestro.positions_us()[3] == 1150.25  # quarter-µs resolution
        assert maestro.errors == 0 and maestro.error_events == 0
    finally:
        await driver.close()


async def test_speed_and_acceleration_from_the_profile(maestro: FakeMaestro) -> None:
    profile = load_profile("paper16")  # max_speed 3000 (eyes 6000, jaw 2500), jaw max_accel 30000
    driver = MaestroDriver(MaestroConfig(port=str(maestro.link), model="mini24"), profile)
    await driver.connect()
    try:
        await maestro.until(lambda: maestro.speeds[11] != 0)
        assert maestro.speeds[:16] == [
            120,
            120,
            120,
            240,
            240,
            240,
            240,
            120,
            120,
            120,
            120,
            100,
            120,
            120,
            120,
            120,
        ]
        assert maestro.accelerations[11] == 96 and maestro.accelerations[0] == 0
    finally:
        await driver.close()
    off = MaestroDriver(MaestroConfig(port=str(maestro.link), speed_limits=False), profile)
    with maestro.lock:
        maestro.reset()
    await off.connect()
    try:
        await maestro.until(lambda: maestro.targets[0] != 0)
        assert commands_of(maestro, mp.SET_SPEED) == []
    finally:
        await off.close()


async def test_a_maestro_error_is_reported_and_the_pose_written_again(
    maestro: FakeMaestro, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(maestro_driver, "CHECK_EVERY_S", 0.1)
    profile = load_profile("paper16")
    driver = MaestroDriver(MaestroConfig(port=str(maestro.link), model="mini24"), profile)
    await driver.connect()
    try:
        await driver.send({"jaw": 1800.0}, INFO)
        await maestro.until(lambda: maestro.targets[11] == 7200)
        # A glitch on the line: a command cut off by the next one.
        with maestro.lock:
            maestro.handle(
                bytes([0x84, 0x00]) + bytes([0xA2])
            )  # interrupted: servos to error state
        assert maestro.targets[11] == 0
        for _ in range(40):
            await driver.send({"jaw": 1800.0}, INFO)
            await asyncio.sleep(0.05)
            if driver.errors_seen:
                break
        assert driver.errors_seen == {"serial protocol error": 1}
        assert "serial protocol error 1x" in driver.state()
        await maestro.until(lambda: maestro.targets[11] == 7200)
        assert maestro.errors & PROTOCOL_ERROR == 0  # read and cleared
    finally:
        await driver.close()


async def test_a_maestro_that_stops_answering_is_reopened(
    maestro: FakeMaestro, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(maestro_driver, "CHECK_EVERY_S", 0.1)
    monkeypatch.setattr(maestro_driver, "REPLY_TIMEOUT_S", 0.3)
    driver = MaestroDriver(
        MaestroConfig(port=str(maestro.link), model="mini24"), load_profile("paper16")
    )
    await driver.connect()
    mute = maestro.handle
    try:
        maestro.handle = lambda data: (mute(data), b"")[1]  # type: ignore[method-assign]
        for _ in range(40):
            await driver.send({"jaw": 1600.0}, INFO)
            await asyncio.sleep(0.05)
            if driver.link.state.losses:
                break
        assert "no answer to Get Errors" in driver.link.state.last_error
        maestro.handle = mute  # type: ignore[method-assign]
        for _ in range(60):
            await driver.send({"jaw": 1700.0}, INFO)
            await asyncio.sleep(0.05)
            if driver.link.connected and maestro.targets[11] == 6800:
                break
        assert driver.link.connected and driver.link.state.connects == 2
    finally:
        maestro.handle = mute  # type: ignore[method-assign]
        await driver.close()


async def test_status_reads_errors_and_positions_without_moving(maestro: FakeMaestro) -> None:
    profile = load_profile("paper16")
    with maestro.lock:
        maestro.targets[11] = 7000
        maestro.errors = 0x0010
    driver = MaestroDriver(MaestroConfig(port=str(maestro.link)), profile)
    await driver.connect_once(query_only=True)
    try:
        status = await driver.device_status()
    finally:
        await driver.close()
    assert status["errors"] == ["serial protocol error"]
    assert status["positions_us"]["jaw"] == 1750.0
    assert commands_of(maestro, mp.SET_TARGET) == commands_of(maestro, mp.SET_SPEED) == []


def test_usb_ids_name_the_model(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    from serial.tools import list_ports_common

    port = list_ports_common.ListPortInfo(str(tmp_path / "ttyACM0"))
    port.vid, port.pid = mp.USB_VENDOR, 0x008A
    monkeypatch.setattr("serial.tools.list_ports.comports", lambda: [port])
    assert maestro_driver.usb_model(str(tmp_path / "ttyACM0")) == "mini12"
    assert maestro_driver.usb_model(str(tmp_path / "ttyUSB1")) is None
    assert maestro_driver.usb_model("socket://h:1") is None


def test_profile_beyond_the_model_is_a_clear_error() -> None:
    with pytest.raises(
        DriverConfigError, match=r"channel 15, but the Micro Maestro 6 has channels 0\.\.5"
    ):
        MaestroDriver(MaestroConfig(port="/dev/null", model="micro6"), load_profile("paper16"))


async def test_a_profile_with_twenty_four_servos(maestro: FakeMaestro, tmp_path: Path) -> None:
    servos = [
        {"name": f"s{ch}", "channel": ch, "min_us": 900, "neutral_us": 1500, "max_us": 2100}
        for ch in range(24)
    ]
    profile = load_profile(str(write_profile(tmp_path / "big.toml", servos)))
    driver = MaestroDriver(MaestroConfig(port=str(maestro.link), model="mini24"), profile)
    await driver.connect()
    try:
        await driver.send({f"s{ch}": 1000.0 + 40 * ch for ch in range(24)}, INFO)
        await maestro.until(lambda: maestro.targets[23] == (1000 + 40 * 23) * 4)
        assert maestro.positions_us() == {ch: 1000.0 + 40 * ch for ch in range(24)}
    finally:
        await driver.close()
