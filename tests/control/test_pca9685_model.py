"""The PCA9685 model itself (fake_devices/pca9685.py) keeps the datasheet's rules, so a driver
that breaks one is caught: PRE_SCALE blocked while awake, no auto-increment without AI, ALL_LED
over every channel, RESTART 500 µs after waking, widths from (OFF − ON) / 4096 × period."""

from __future__ import annotations

import time

import pytest
import smbus2
from fake_devices.pca9685 import FakePCA9685, FakeSMBus
from hypothesis import given, settings
from hypothesis import strategies as st

from facesynth.services.control.drivers.pca9685 import registers as reg

ADDRESS = 0x40


@pytest.fixture
def chip() -> FakePCA9685:
    return FakePCA9685()


def awake(chip: FakePCA9685, prescale: int = 121) -> FakeSMBus:
    bus = FakeSMBus(chip, "/dev/i2c-1")
    bus.write_byte_data(ADDRESS, 0x00, 0x31)  # asleep, AI
    bus.write_byte_data(ADDRESS, 0xFE, prescale)
    bus.write_byte_data(ADDRESS, 0x00, 0x21)  # awake, AI
    return bus


def test_power_on_state(chip: FakePCA9685) -> None:
    bus = FakeSMBus(chip, "/dev/i2c-1")
    assert bus.read_byte_data(ADDRESS, 0x00) == 0x11 and bus.read_byte_data(ADDRESS, 0x01) == 0x04
    assert bus.read_byte_data(ADDRESS, 0xFE) == 30 and chip.widths_us() == {}


def test_prescale_is_blocked_while_awake(chip: FakePCA9685) -> None:
    bus = awake(chip, prescale=121)
    bus.write_byte_data(ADDRESS, 0xFE, 60)
    assert bus.read_byte_data(ADDRESS, 0xFE) == 121
    assert chip.violations == ["PRE_SCALE written while awake (blocked)"]


def test_prescale_below_three_is_three(chip: FakePCA9685) -> None:
    bus = FakeSMBus(chip, "/dev/i2c-1")
    bus.write_byte_data(ADDRESS, 0xFE, 1)
    assert bus.read_byte_data(ADDRESS, 0xFE) == 3


def test_without_auto_increment_every_byte_lands_on_one_register(chip: FakePCA9685) -> None:
    bus = FakeSMBus(chip, "/dev/i2c-1")
    bus.write_byte_data(ADDRESS, 0xFE, 121)
    bus.write_byte_data(ADDRESS, 0x00, 0x01)  # awake, AI off
    bus.i2c_rdwr(smbus2.i2c_msg.write(ADDRESS, [0x06, 0, 0, 0x34, 0x01]))
    assert list(chip.regs[0x06:0x0A]) == [0x01, 0, 0, 0x10]  # LED0_ON_L took every byte
    assert chip.widths_us() == {}


def test_auto_increment_block_and_the_width_formula(chip: FakePCA9685) -> None:
    bus = awake(chip)
    bus.i2c_rdwr(smbus2.i2c_msg.write(ADDRESS, [0x06 + 4 * 3, 0x10, 0, 0x44, 0x01]))
    period = 4096 * 122 / 25e6 * 1e6
    assert chip.widths_us() == {3: pytest.approx((0x144 - 0x10) / 4096 * period)}
    read = [smbus2.i2c_msg.write(ADDRESS, [0x06 + 4 * 3]), smbus2.i2c_msg.read(ADDRESS, 4)]
    bus.i2c_rdwr(*read)
    assert bytes(read[1]) == bytes((0x10, 0, 0x44, 0x01))


def test_all_led_writes_every_channel_and_reads_zero(chip: FakePCA9685) -> None:
    bus = awake(chip)
    bus.i2c_rdwr(smbus2.i2c_msg.write(ADDRESS, [0xFA, 0, 0, 0x30, 0x01]))
    assert set(chip.widths_us()) == set(range(16))
    assert bus.read_byte_data(ADDRESS, 0xFC) == 0


def test_sleep_with_active_channels_sets_restart(chip: FakePCA9685) -> None:
    bus = awake(chip)
    bus.i2c_rdwr(smbus2.i2c_msg.write(ADDRESS, [0x06, 0, 0, 0x30, 0x01]))
    bus.write_byte_data(ADDRESS, 0x00, 0x31)
    assert bus.read_byte_data(ADDRESS, 0x00) & 0x80 and chip.widths_us() == {}
    bus.write_byte_data(ADDRESS, 0x00, 0x21)  # awake, but waiting for RESTART
    assert chip.widths_us() == {}
    bus.write_byte_data(ADDRESS, 0x00, 0xA1)  # too early
    assert chip.violations == ["RESTART less than 500 us after SLEEP was cleared"]
    assert bus.read_byte_data(ADDRESS, 0x00) == 0x21 and set(chip.widths_us()) == {0}


def test_restart_after_the_oscillator_settles_is_clean(chip: FakePCA9685) -> None:
    bus = awake(chip)
    bus.i2c_rdwr(smbus2.i2c_msg.write(ADDRESS, [0x06, 0, 0, 0x30, 0x01]))
    bus.write_byte_data(ADDRESS, 0x00, 0x31)
    bus.write_byte_data(ADDRESS, 0x00, 0x21)
    time.sleep(0.001)
    bus.write_byte_data(ADDRESS, 0x00, 0xA1)
    assert not chip.violations and set(chip.widths_us()) == {0}


def test_another_address_gets_no_acknowledge(chip: FakePCA9685) -> None:
    bus = FakeSMBus(chip, "/dev/i2c-1")
    with pytest.raises(OSError, match="Remote I/O error"):
        bus.read_byte_data(0x41, 0x00)


@settings(max_examples=200, deadline=None)
@given(st.dictionaries(st.integers(0, 15), st.integers(1, 4095), min_size=1))
def test_any_pose_block_makes_exactly_its_widths(pose: dict[int, int]) -> None:
    """The driver's encoder against the model: a block over any channels gives each its
    width and leaves the channels between them without pulses."""
    chip = FakePCA9685()
    bus = awake(chip)
    bus.i2c_rdwr(smbus2.i2c_msg.write(ADDRESS, reg.pose_block(pose)))
    tick = 122 / 25e6 * 1e6
    assert chip.widths_us() == {ch: pytest.approx(t * tick) for ch, t in pose.items()}
    assert not chip.violations
