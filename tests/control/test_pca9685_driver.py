"""The ``pca9685`` driver against the register-exact PCA9685 model (fake_devices/pca9685.py):
the datasheet's start-up order, one auto-increment block per pose, the pulse widths the
registers make, a board that loses power, neutral then sleep at close, and ``control status``."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest
from fake_devices.pca9685 import FakeI2CAdapter, FakePCA9685
from profile_files import write_profile

from facesynth.app.control_tools import run_test, show_status
from facesynth.runtime.profiles import load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DeviceUnavailable
from facesynth.services.control.drivers.pca9685 import PCA9685Config, PCA9685Driver
from facesynth.services.control.drivers.registry import DRIVERS

PAPER16 = load_profile("paper16")
INFO = CommandInfo(1, None, True)


def make(adapter: FakeI2CAdapter, **fields: Any) -> PCA9685Driver:
    config = DRIVERS.parse({"driver": "pca9685", "bus": str(adapter.path), **fields})
    assert isinstance(config, PCA9685Config)
    return PCA9685Driver(config, PAPER16, open_bus=adapter.open)


@pytest.fixture
def chip() -> FakePCA9685:
    return FakePCA9685()


@pytest.fixture
def adapter(tmp_path: Path, chip: FakePCA9685) -> FakeI2CAdapter:
    return FakeI2CAdapter(tmp_path / "i2c-1", chip)


def widths_by_servo(chip: FakePCA9685) -> dict[str, float]:
    widths = chip.widths_us()
    return {s.name: widths[s.channel] for s in PAPER16.servos if s.channel in widths}


def log(chip: FakePCA9685, since: int = 0) -> list[tuple[int, str]]:
    """The chip's I2C writes: (register, data hex); a pointer set for a read has no data."""
    return [(w.register, w.data.hex()) for w in chip.writes[since:]]


async def test_start_up_follows_the_datasheet(adapter: FakeI2CAdapter, chip: FakePCA9685) -> None:
    driver = make(adapter, exit_hold_s=0)
    await driver.connect()
    try:
        assert log(chip)[:6] == [
            (0x00, ""),  # read MODE1 (0x11 at power-on: SLEEP, ALLCALL)
            (0x00, "31"),  # MODE1: SLEEP + AI, ALLCALL kept: the oscillator off
            (0xFE, f"{round(25e6 / (4096 * 50)) - 1:02x}"),  # PRE_SCALE 121, written asleep
            (0x01, "04"),  # MODE2: totem-pole outputs
            (0x00, "21"),  # MODE1: awake, auto-increment
            (0x00, ""),  # read MODE1: no RESTART pending on a fresh chip, none written
        ]
        assert chip.regs[0xFE] == 121 and not chip.asleep and not chip.violations
        assert widths_by_servo(chip) == {
            name: pytest.approx(us, abs=4.89) for name, us in PAPER16.neutral_positions().items()
        }
    finally:
        await driver.close()


async def test_a_running_chip_is_restarted_after_the_oscillator_settles(
    adapter: FakeI2CAdapter, chip: FakePCA9685
) -> None:
    """A chip left running (the last process died) goes to sleep with RESTART set; the driver
    writes RESTART only after 500 µs awake (the model records an early one as a violation)."""
    first = make(adapter)
    await first.connect()  # and never closed: the process is gone
    second = make(adapter, exit_hold_s=0)
    since = len(chip.writes)
    await second.connect()
    try:
        assert log(chip, since)[4:7] == [(0x00, "21"), (0x00, ""), (0x00, "a1")]
        assert chip.running() and not chip.violations
    finally:
        await second.close()


async def test_each_pose_is_one_auto_increment_block(
    adapter: FakeI2CAdapter, chip: FakePCA9685
) -> None:
    driver = make(adapter, exit_hold_s=0)
    await driver.connect()
    try:
        bus = adapter.opened[-1]
        calls, writes = bus.calls, len(chip.writes)
        pose = {s.name: s.min_us + 0.3 * (s.max_us - s.min_us) for s in PAPER16.servos}
        await driver.send(pose, INFO)
        await driver.flush()
        assert bus.calls == calls + 1  # one i2c_rdwr, one message
        [block] = chip.writes[writes:]
        assert block.register == 0x06 and len(block.data) == 16 * 4  # LED0_ON_L.., 65 bytes
        assert widths_by_servo(chip) == {n: pytest.approx(v, abs=4.89) for n, v in pose.items()}
    finally:
        await driver.close()


async def test_channels_between_the_profiles_are_written_full_off(tmp_path: Path) -> None:
    """A profile on channels 2 and 5: one block over 2..5, channels 3 and 4 full off."""
    servos = [
        {"name": name, "channel": ch, "min_us": 1000, "neutral_us": 1500, "max_us": 2000}
        for name, ch in (("jaw", 2), ("brow", 5))
    ]
    small = load_profile(str(write_profile(tmp_path / "small.toml", servos)))
    chip = FakePCA9685()
    adapter = FakeI2CAdapter(tmp_path / "i2c-1", chip)
    config = DRIVERS.parse({"driver": "pca9685", "bus": str(adapter.path), "exit_hold_s": 0})
    assert isinstance(config, PCA9685Config)
    driver = PCA9685Driver(config, small, open_bus=adapter.open)
    await driver.connect()
    try:
        block = chip.writes[-1]
        assert block.register == 0x06 + 4 * 2 and len(block.data) == 4 * 4
        assert block.data[4:12] == bytes((0, 0, 0, 0x10)) * 2
        assert set(chip.widths_us()) == {2, 5}
    finally:
        await driver.close()


@pytest.mark.parametrize(("oscillator", "frequency"), [(25e6, 50.0), (26.8e6, 50.0), (25e6, 60.0)])
async def test_pulse_widths_follow_the_oscillator_and_frame_rate(
    tmp_path: Path, oscillator: float, frequency: float
) -> None:
    """With the board's true oscillator given, the widths are exact to a tick at any rate."""
    chip = FakePCA9685(oscillator_hz=oscillator)
    adapter = FakeI2CAdapter(tmp_path / "i2c-1", chip)
    driver = make(adapter, oscillator_hz=oscillator, frequency_hz=frequency, exit_hold_s=0)
    await driver.connect()
    try:
        prescale = round(oscillator / (4096 * frequency)) - 1
        tick = (prescale + 1) / oscillator * 1e6
        assert chip.regs[0xFE] == prescale
        assert chip.period_us == pytest.approx(1e6 / frequency, rel=0.01)
        pose = {s.name: s.min_us + 0.6 * (s.max_us - s.min_us) for s in PAPER16.servos}
        await driver.send(pose, INFO)
        await driver.flush()
        want = {n: pytest.approx(v, abs=tick / 2 + 1e-6) for n, v in pose.items()}
        assert widths_by_servo(chip) == want
    finally:
        await driver.close()


async def test_a_wrong_oscillator_setting_shows_in_the_widths(tmp_path: Path) -> None:
    """A board whose oscillator runs at 27 MHz, driven as if at 25: widths 7 % short (why the
    oscillator is an option)."""
    chip = FakePCA9685(oscillator_hz=27e6)
    driver = make(FakeI2CAdapter(tmp_path / "i2c-1", chip), exit_hold_s=0)
    await driver.connect()
    try:
        await driver.send({"jaw": 1600.0}, INFO)
        await driver.flush()
        jaw = next(s.channel for s in PAPER16.servos if s.name == "jaw")
        assert chip.width_us(jaw) == pytest.approx(1600 * 25 / 27, abs=5)
    finally:
        await driver.close()


async def test_close_puts_out_neutral_then_sleeps(
    adapter: FakeI2CAdapter, chip: FakePCA9685
) -> None:
    driver = make(adapter, exit_hold_s=0.05)
    await driver.connect()
    await driver.send({s.name: s.max_us for s in PAPER16.servos}, INFO)
    await driver.flush()
    since = len(chip.writes)
    await driver.close()
    closing = chip.writes[since:]
    assert closing[0].register == 0x06  # the neutral block first
    assert [(w.register, w.data.hex()) for w in closing[1:]] == [(0x00, ""), (0x00, "31")]
    assert chip.asleep and not chip.running()
    for spec in PAPER16.servos:  # the registers hold neutral (asleep: no pulses)
        assert chip.width_us(spec.channel, programmed=True) == pytest.approx(
            spec.neutral_us, abs=4.89
        )
    assert adapter.opened[-1].closed


async def test_a_board_that_loses_power_is_programmed_again(
    adapter: FakeI2CAdapter, chip: FakePCA9685
) -> None:
    driver = make(adapter, exit_hold_s=0)
    await driver.connect()
    try:
        adapter.unplug()
        held = {s.name: s.min_us + 0.8 * (s.max_us - s.min_us) for s in PAPER16.servos}
        await driver.send(held, INFO)  # no exception: the write fails on the I2C thread
        for _ in range(100):
            if "disconnected" in driver.state():
                break
            await asyncio.sleep(0.01)
        await driver.send(held, INFO)  # counted and dropped
        assert "disconnected" in driver.state() and "Remote I/O error" in driver.state()
        assert "1 writes dropped" in driver.state()
        adapter.plug()  # a power-on reset: PRE_SCALE back to 30 (200 Hz)
        for _ in range(100):
            if "disconnected" not in driver.state():
                break
            await asyncio.sleep(0.05)
        assert chip.regs[0xFE] == 121 and not chip.violations
        assert widths_by_servo(chip) == {n: pytest.approx(v, abs=4.89) for n, v in held.items()}
    finally:
        await driver.close()


async def test_control_status_reads_the_registers(
    adapter: FakeI2CAdapter, chip: FakePCA9685
) -> None:
    driver = make(adapter, exit_hold_s=0)
    await driver.connect()
    await driver.send({"jaw": 1700.0}, INFO)
    await driver.close()
    since = len(chip.writes)
    status = make(adapter)
    await status.connect_once(query_only=True)
    try:
        report = await status.device_status()
    finally:
        await status.close()
    assert all(w.data == b"" or w.register != 0 for w in chip.writes[since:])  # nothing written
    assert report["mode1"] == "0xb1 (asleep)" and report["prescale"] == 121
    assert report["frequency_hz"] == pytest.approx(50.03, abs=0.01)
    assert report["pulses_us"]["jaw"] == pytest.approx(PAPER16.neutral_positions()["jaw"], abs=4.89)


async def test_a_missing_bus_is_one_line(tmp_path: Path) -> None:
    """The real smbus2 opening a /dev/i2c-N that is not there (no kernel module here)."""
    config = DRIVERS.parse({"driver": "pca9685", "bus": "/dev/i2c-99"})
    driver = DRIVERS.build(config, PAPER16)
    with pytest.raises(DeviceUnavailable) as info:
        await driver.connect_once()
    assert str(info.value) == "/dev/i2c-99: cannot open it: No such file or directory"


async def test_a_board_that_does_not_answer_is_one_line(tmp_path: Path) -> None:
    chip = FakePCA9685(address=0x41)
    driver = make(FakeI2CAdapter(tmp_path / "i2c-1", chip))
    with pytest.raises(DeviceUnavailable) as info:
        await driver.connect_once()
    assert str(info.value) == f"{tmp_path}/i2c-1: no device answers at 0x40 (Remote I/O error)"


def test_addresses_are_read_as_people_write_them(adapter: FakeI2CAdapter) -> None:
    for text, value in [("0x41", 0x41), ("65", 65), ("41h", 0x41), (0x70, 0x70)]:
        assert make(adapter, address=text).address == value


async def test_control_test_sweeps_one_servo_and_leaves_the_board_asleep_at_neutral(
    adapter: FakeI2CAdapter, chip: FakePCA9685
) -> None:
    """``facesynth control test --driver pca9685 --servo jaw``'s sweep, on the model."""
    jaw = PAPER16.servo("jaw")
    lines: list[str] = []
    await run_test(make(adapter, exit_hold_s=0), PAPER16, ["jaw"], speed=4000, hold=0.05,
                   out=lines.append)  # fmt: skip
    widths = [pose[jaw.channel] for pose in chip.history if jaw.channel in pose]
    tick = 122 / 25e6 * 1e6
    assert min(widths) == pytest.approx(jaw.min_us, abs=tick)  # out to each limit and back
    assert max(widths) == pytest.approx(jaw.max_us, abs=tick)
    others = {ch for pose in chip.history for ch, w in pose.items() if ch != jaw.channel}
    neutral = {s.channel: s.neutral_us for s in PAPER16.servos}
    for pose in chip.history:  # the others held at neutral
        for ch in others & set(pose):
            assert pose[ch] == pytest.approx(neutral[ch], abs=tick)
    assert lines[-1] == "done: every servo at neutral" and chip.asleep and not chip.violations


async def test_control_status_prints_the_registers(adapter: FakeI2CAdapter) -> None:
    lines: list[str] = []
    assert await show_status(make(adapter), out=lines.append) == 0
    text = lines[0]
    assert "mode1         0x11 (asleep)" in text and "prescale      30" in text  # power-on
    assert "pulses_us" in text
