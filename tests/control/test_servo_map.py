"""facesynth.services.control.drivers.servo_map: channels, inward-rounded limits, the last clamp."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from profile_files import write_profile

from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.drivers.base import DriverConfigError, DriverError
from facesynth.services.control.drivers.servo_map import ServoMap


def odd_profile(tmp_path: Path) -> Profile:
    servos = [
        {"name": "a", "channel": 3, "min_us": 1000.3, "neutral_us": 1500.6, "max_us": 1999.9},
        {"name": "b", "channel": 20, "min_us": 600, "neutral_us": 600, "max_us": 2400},
    ]
    return load_profile(str(write_profile(tmp_path / "odd.toml", servos)))


def test_limits_round_inward_to_the_board_resolution(tmp_path: Path) -> None:
    profile = odd_profile(tmp_path)
    us = ServoMap(profile, board="b", step_us=1, range_us=(500, 2500), channels=None)
    assert (us.limits[3].low, us.limits[3].neutral, us.limits[3].high) == (1001, 1501, 1999)
    quarter = ServoMap(profile, board="b", step_us=0.25, range_us=(0.25, 4000), channels=None)
    assert (quarter.limits[3].low, quarter.limits[3].high) == (4002, 7999)  # 1000.5, 1999.75
    assert quarter.us(quarter.limits[3].low) == 1000.5
    assert us.channels == [3, 20] and us.neutral_pose() == {3: 1501, 20: 600}


def test_every_position_is_clamped_and_rounded(tmp_path: Path) -> None:
    servo_map = ServoMap(
        odd_profile(tmp_path), board="b", step_us=1, range_us=(500, 2500), channels=None
    )
    pose = servo_map.pose({"a": 5000.0, "b": 1234.6}, servo_map.neutral_pose())
    assert pose == {3: 1999, 20: 1235}
    pose = servo_map.pose({"a": -5.0}, pose)  # b holds its position
    assert pose == {3: 1001, 20: 1235}
    # The step right before encoding clamps even a pose built elsewhere.
    assert servo_map.checked({3: 9000, 20: 100, 7: 1500}) == {3: 1999, 20: 600}


def test_unknown_servos_and_non_finite_values_raise(tmp_path: Path) -> None:
    servo_map = ServoMap(
        odd_profile(tmp_path), board="b", step_us=1, range_us=(500, 2500), channels=None
    )
    with pytest.raises(DriverError, match="servo 'c' is not in profile 'testface'"):
        servo_map.pose({"c": 1500.0}, {})
    for value in (math.nan, math.inf):
        with pytest.raises(DriverError, match="position of 'a'"):
            servo_map.pose({"a": value}, {})


def test_what_the_board_cannot_drive_is_named(tmp_path: Path) -> None:
    profile = odd_profile(tmp_path)
    with pytest.raises(
        DriverConfigError,
        match=re.escape(
            "servo 'b' (channel 20): limits 600..2400 us are outside what the X drives"
        ),
    ):
        ServoMap(profile, board="X", step_us=1, range_us=(700, 2500), channels=None)
    with pytest.raises(
        DriverConfigError,
        match=re.escape("puts servo 'b' on channel 20, but the X has channels 0..15"),
    ):
        ServoMap(profile, board="X", step_us=1, range_us=(500, 2500), channels=16)
    servo_map = ServoMap(profile, board="X", step_us=1, range_us=(500, 2500), channels=None)
    with pytest.raises(DriverConfigError, match=re.escape("the Y has channels 0..5")):
        servo_map.check_channels(6, "Y")
    servo_map.check_channels(21)
