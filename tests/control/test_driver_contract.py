"""The servo driver contract, run against every registered driver (see driver_rigs.py).

Every driver connects, moves each servo to the position it is given and returns to neutral,
closes and connects again; it never lets a position outside the profile's limits reach the
device, refuses unknown servos and non-finite positions, and refuses configs that cannot work
with one clear line. Drivers of devices that can be unplugged keep running while unplugged
(their sends do not raise) and carry on when the device is back, without a restart.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Iterator
from pathlib import Path

import pytest
from driver_rigs import NEEDS_FIRMWARE, RIGS, DriverRig

from facesynth.runtime.plugins import PluginError
from facesynth.runtime.profiles import Profile, load_profile
from services.control.core import CommandInfo
from services.control.drivers.base import DeviceUnavailable, DriverConfigError, DriverError
from services.control.drivers.registry import DRIVERS

INFO = CommandInfo(frame=3, t_capture_ns=None, face=True)


@pytest.fixture
def profile() -> Profile:
    return load_profile("paper16")


@pytest.fixture(params=sorted(RIGS))
def rig(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[DriverRig]:
    if request.param in NEEDS_FIRMWARE:
        request.getfixturevalue("firmware_ready")
    made = RIGS[request.param](tmp_path)
    yield made
    made.close()


@pytest.fixture(params=sorted(name for name, make in RIGS.items() if make.can_unplug))  # type: ignore[attr-defined]
def pluggable(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[DriverRig]:
    if request.param in NEEDS_FIRMWARE:
        request.getfixturevalue("firmware_ready")
    made = RIGS[request.param](tmp_path)
    yield made
    made.close()


def pose(profile: Profile, shift: float) -> dict[str, float]:
    """Each servo somewhere different inside its limits."""
    count = len(profile.servos)
    return {
        s.name: s.min_us + (s.max_us - s.min_us) * ((0.15 + 0.7 * i / count + shift) % 1.0)
        for i, s in enumerate(profile.servos)
    }


def test_every_registered_driver_has_a_rig() -> None:
    assert set(DRIVERS.names()) <= set(RIGS), "add a rig for the new driver to driver_rigs.py"


async def test_connect_send_neutral_close_and_connect_again(
    rig: DriverRig, profile: Profile
) -> None:
    driver = rig.make(profile)
    await driver.connect()
    try:
        first = pose(profile, 0.0)
        await driver.send(first, INFO)
        await rig.wait_shown(profile, first)
        await driver.neutral(profile.neutral_positions())
        await rig.wait_shown(profile, profile.neutral_positions())
    finally:
        await driver.close()
    await driver.connect()  # the same driver object, opened again
    try:
        second = pose(profile, 0.4)
        await driver.send(second, INFO)
        await rig.wait_shown(profile, second)
    finally:
        await driver.close()


async def test_positions_outside_the_limits_never_reach_the_device(
    rig: DriverRig, profile: Profile
) -> None:
    driver = rig.make(profile)
    await driver.connect()
    try:
        wild = {s.name: (-1e6 if i % 2 else 1e6) for i, s in enumerate(profile.servos)}
        await driver.send(wild, INFO)
        edges = {s.name: (s.min_us if i % 2 else s.max_us) for i, s in enumerate(profile.servos)}
        await rig.wait_shown(profile, edges)
        for spec in profile.servos:
            assert (
                spec.min_us - rig.tolerance_us
                <= rig.shown(profile)[spec.name]
                <= spec.max_us + rig.tolerance_us
            )
    finally:
        await driver.close()


async def test_unknown_servos_and_non_finite_positions_are_refused(
    rig: DriverRig, profile: Profile
) -> None:
    driver = rig.make(profile)
    await driver.connect()
    try:
        start = pose(profile, 0.2)
        await driver.send(start, INFO)
        await rig.wait_shown(profile, start)
        with pytest.raises(DriverError, match="'nose' is not in"):
            await driver.send({"nose": 1500.0}, INFO)
        with pytest.raises(DriverError, match="position of 'jaw' is nan"):
            await driver.send({"jaw": math.nan}, INFO)
        await asyncio.sleep(0.2)
        await rig.wait_shown(profile, start)  # nothing moved
    finally:
        await driver.close()


async def test_bad_configs_are_refused_with_one_clear_line(
    rig: DriverRig, profile: Profile
) -> None:
    for config, message in rig.bad_configs():
        with pytest.raises((PluginError, DriverConfigError)) as info:
            driver = DRIVERS.build(DRIVERS.parse(config), profile)
            await driver.connect()  # some problems show only when the device answers
            await driver.close()
        assert message in str(info.value), (config, str(info.value))
        assert "\n" not in str(info.value)


async def test_a_missing_device_is_a_clear_error_for_one_off_tools(
    rig: DriverRig, profile: Profile
) -> None:
    config = rig.missing_device()
    assert config is not None
    driver = DRIVERS.build(DRIVERS.parse(config), profile)
    with pytest.raises((DeviceUnavailable, DriverError)) as info:
        await driver.connect_once()
    assert "\n" not in str(info.value)
    await driver.close()


async def test_unplugged_device_keeps_the_driver_alive_until_it_is_back(
    pluggable: DriverRig, profile: Profile
) -> None:
    rig = pluggable
    driver = rig.make(profile)
    await driver.connect()
    try:
        before = pose(profile, 0.1)
        await driver.send(before, INFO)
        await rig.wait_shown(profile, before)
        rig.unplug()
        meanwhile = pose(profile, 0.3)
        for _ in range(10):  # as the control service would: no exception escapes
            await driver.send(meanwhile, INFO)
            await asyncio.sleep(0.05)
        assert "disconnected" in driver.state()
        rig.plug()
        # The pose the driver holds (the last one sent) comes back without another command.
        await rig.wait_shown(profile, meanwhile)
        after = pose(profile, 0.6)
        await driver.send(after, INFO)
        await rig.wait_shown(profile, after)
        assert "connected" in driver.state() and "disconnected" not in driver.state()
    finally:
        await driver.close()


async def test_a_device_not_there_at_start_is_waited_for(
    pluggable: DriverRig, profile: Profile
) -> None:
    rig = pluggable
    rig.unplug()
    driver = rig.make(profile)
    await driver.connect()  # the service starts anyway
    try:
        wanted = pose(profile, 0.5)
        await driver.send(wanted, INFO)
        assert "disconnected" in driver.state()
        rig.plug()
        await rig.wait_shown(profile, wanted)
    finally:
        await driver.close()
