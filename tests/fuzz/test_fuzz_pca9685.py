"""Fuzz the pca9685 driver's readers: a channel's four registers read back from the chip
(``control status``) and the I2C address as a person writes it (``--i2c-address``)."""

from __future__ import annotations

import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome, tally
from hypothesis import given
from hypothesis import strategies as st

from facesynth.services.control.drivers.base import DriverConfigError
from facesynth.services.control.drivers.pca9685 import registers as reg

pytestmark = [pytest.mark.fuzz, TIMEOUT]


def test_channel_registers_read_back_as_a_pulse_length() -> None:
    target = "pca9685 pulse_ticks (register read-back)"
    record = tally(target)

    @FUZZ
    @given(st.one_of(st.binary(min_size=4, max_size=4), st.integers(1, reg.TICKS - 1)))
    def case(raw: bytes | int) -> None:
        if isinstance(raw, int):  # what the driver writes reads back as itself
            block = reg.pose_block({0: raw, 2: raw})
            assert reg.pulse_ticks(block[1:5]) == reg.pulse_ticks(block[9:13]) == raw
            assert reg.pulse_ticks(block[5:9]) == 0  # the channel between: full off
            record.count("written")
            return
        ticks = reg.pulse_ticks(raw)
        assert 0 <= ticks <= reg.TICKS
        record.count("full" if raw[1] & reg.FULL or raw[3] & reg.FULL else "any")

    case()
    check_tally(target, "written", "full", "any")


def test_i2c_addresses_parse_or_are_one_line_refusals() -> None:
    target = "pca9685 parse_address (--i2c-address)"

    @FUZZ
    @given(
        st.one_of(
            st.text(max_size=12),
            st.integers(-(2**40), 2**40),
            st.integers(0, 0x7F).map(hex),
            st.integers(0, 0x7F).map(lambda n: f"{n:02x}h"),
        )
    )
    def case(text: str | int) -> None:
        value = outcome(target, lambda: reg.parse_address(text), DriverConfigError)
        if value is not None:
            assert 0x03 <= value <= 0x77

    case()
    check_tally(target, "valid", "refused")
