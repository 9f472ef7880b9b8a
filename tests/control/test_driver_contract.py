"""One contract, every servo driver: record, virtual (live page), vmc (avatar over OSC), and the
boards: maestro and ssc32 (fakes on ptys) and arduino (the real firmware on the emulated Uno).

Each rig (driver_rigs.py) builds its driver and reads back what reached the outside world in
the outside's own form. Every driver puts out what it is sent and the neutral face; it never
lets a position outside the profile's limits out, refuses unknown servos and non-finite
positions, is an error to use before connect or after close, connects again after close, and
refuses settings that cannot work with one clear line. Drivers of devices that can be
unplugged keep running while unplugged (sends do not raise) and carry on when the device is
back, without a restart; a device missing at start is waited for, and is a clear error for
one-off tools.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
from driver_rigs import ELSEWHERE, RIGS, DriverRig

from facesynth.runtime.plugins import PluginError
from facesynth.runtime.profiles import Profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverConfigError, DriverError, ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS


async def _rig(request: pytest.FixtureRequest, tmp_path: Path) -> AsyncIterator[DriverRig]:
    make = RIGS[request.param]
    if make.needs_firmware:
        request.getfixturevalue("firmware_ready")
    made = make(tmp_path)
    try:
        yield made
    finally:
        await made.aclose()


@pytest.fixture(params=sorted(RIGS))
async def rig(request: pytest.FixtureRequest, tmp_path: Path) -> AsyncIterator[DriverRig]:
    async for made in _rig(request, tmp_path):
        yield made


@pytest.fixture(params=sorted(name for name, make in RIGS.items() if make.can_unplug))
async def pluggable(request: pytest.FixtureRequest, tmp_path: Path) -> AsyncIterator[DriverRig]:
    async for made in _rig(request, tmp_path):
        yield made


@pytest.fixture(params=sorted(name for name, make in RIGS.items() if make.has_device_path))
async def with_device_path(
    request: pytest.FixtureRequest, tmp_path: Path
) -> AsyncIterator[DriverRig]:
    async for made in _rig(request, tmp_path):
        yield made


class Session:
    """A connected driver whose commands are numbered, so the rig knows which one it sees."""

    def __init__(self, rig: DriverRig) -> None:
        self.rig = rig
        self.driver: ServoDriver = rig.make()
        self.count = 0

    async def connect(self) -> Session:
        await self.driver.connect()
        await self.rig.after_connect(self.driver, self.count)
        return self

    async def send(self, positions: dict[str, float]) -> None:
        self.count += 1
        await self.driver.send(positions, CommandInfo(self.count, None, True))

    async def neutral(self) -> None:
        self.count += 1
        await self.driver.neutral(self.rig.profile.neutral_positions())

    async def shows(self, positions: dict[str, float]) -> None:
        await self.rig.shows(positions, self.count)

    async def close(self) -> None:
        await self.driver.close()


@pytest.fixture
async def session(rig: DriverRig) -> AsyncIterator[Session]:
    made = await Session(rig).connect()
    try:
        yield made
    finally:
        await made.close()


def pose(profile: Profile, shift: float) -> dict[str, float]:
    """Each servo somewhere different inside its limits."""
    count = len(profile.servos)
    return {
        s.name: s.min_us + (s.max_us - s.min_us) * ((0.15 + 0.7 * i / count + shift) % 1.0)
        for i, s in enumerate(profile.servos)
    }


def test_every_registered_driver_has_a_rig() -> None:
    assert set(DRIVERS.names()) == set(RIGS) | set(ELSEWHERE), (
        "add a rig for the new driver to driver_rigs.py"
    )
    root = Path(__file__).resolve().parents[2]
    for name, where in ELSEWHERE.items():
        assert f"{name!r}" in (root / where).read_text(), f"{where} runs no {name} rig"


async def test_what_is_sent_is_what_comes_out(session: Session) -> None:
    values = pose(session.rig.profile, 0.0)
    await session.send(values)
    await session.shows(values)


async def test_neutral_puts_out_the_neutral_face(session: Session) -> None:
    await session.send(pose(session.rig.profile, 0.3))
    await session.neutral()
    await session.shows(session.rig.profile.neutral_positions())


async def test_limits_come_out_as_limits(session: Session) -> None:
    """The profile's extremes pass through unchanged."""
    profile = session.rig.profile
    low = {spec.name: spec.min_us for spec in profile.servos}
    high = {spec.name: spec.max_us for spec in profile.servos}
    await session.send(low)
    await session.shows(low)
    await session.send(high)
    await session.shows(high)


async def test_positions_outside_the_limits_never_come_out(session: Session) -> None:
    """Given values outside the limits (the control core never passes them), a driver clamps
    them before anything leaves it."""
    profile = session.rig.profile
    wild = {s.name: (-1e6 if i % 2 else 1e6) for i, s in enumerate(profile.servos)}
    await session.send(wild)
    await session.shows(
        {s.name: (s.min_us if i % 2 else s.max_us) for i, s in enumerate(profile.servos)}
    )


async def test_the_last_of_many_commands_is_what_stays(session: Session) -> None:
    for i in range(30):
        await session.send(pose(session.rig.profile, i / 30))
    await session.shows(pose(session.rig.profile, 29 / 30))


async def test_unknown_servos_and_non_finite_positions_are_refused(session: Session) -> None:
    start = pose(session.rig.profile, 0.2)
    await session.send(start)
    await session.shows(start)
    first = session.rig.profile.servos[0].name
    with pytest.raises(DriverError, match="'nose' is not in"):
        await session.driver.send({"nose": 1500.0}, CommandInfo(None, None, True))
    with pytest.raises(DriverError, match=f"position of '{first}' is nan"):
        await session.driver.send({first: math.nan}, CommandInfo(None, None, True))
    await asyncio.sleep(0.2)
    await session.shows(start)  # nothing came out


async def test_send_before_connect_and_after_close_is_a_driver_error(rig: DriverRig) -> None:
    driver = rig.make()
    values = rig.profile.neutral_positions()
    with pytest.raises(DriverError):
        await driver.send(values, CommandInfo(1, None, True))
    await driver.connect()
    await driver.close()
    await driver.close()  # twice is harmless
    with pytest.raises(DriverError):
        await driver.send(values, CommandInfo(2, None, True))


async def test_async_with_connects_and_closes_even_when_the_block_fails(rig: DriverRig) -> None:
    driver = rig.make()
    values = rig.profile.neutral_positions()
    with pytest.raises(KeyError, match="stop"):
        async with driver as entered:
            assert entered is driver
            await driver.send(values, CommandInfo(1, None, True))
            raise KeyError("stop")
    with pytest.raises(DriverError):  # closed on the way out
        await driver.send(values, CommandInfo(2, None, True))


async def test_close_without_connect_is_harmless(rig: DriverRig) -> None:
    await rig.make().close()


async def test_connect_again_after_close(session: Session) -> None:
    profile = session.rig.profile
    await session.send(pose(profile, 0.1))
    await session.shows(pose(profile, 0.1))
    await session.driver.close()
    await session.connect()  # the same driver object, opened again
    await session.send(pose(profile, 0.5))
    await session.shows(pose(profile, 0.5))


def test_malformed_settings_are_refused_naming_the_field(rig: DriverRig) -> None:
    with pytest.raises(PluginError, match="unknown field `nope`"):
        DRIVERS.parse({**rig.config(), "nope": 1})


async def test_settings_that_cannot_work_are_one_clear_line(rig: DriverRig) -> None:
    for config, message in rig.bad_configs():
        with pytest.raises((PluginError, DriverConfigError, ValueError)) as info:
            driver = DRIVERS.build(DRIVERS.parse(config), rig.profile)
            await driver.connect()  # some problems show only when the device answers
            await driver.close()
        assert message in str(info.value), (config, str(info.value))
        assert "\n" not in str(info.value)


async def test_a_missing_device_is_a_clear_error_for_one_off_tools(
    with_device_path: DriverRig,
) -> None:
    rig = with_device_path
    driver = DRIVERS.build(DRIVERS.parse(rig.missing_device()), rig.profile)
    with pytest.raises(DriverError, match="no-such-port: cannot open it") as info:
        await driver.connect_once()
    assert isinstance(info.value, ValueError) and "\n" not in str(info.value)
    await driver.close()


async def test_an_unplugged_device_keeps_the_driver_alive_until_it_is_back(
    pluggable: DriverRig,
) -> None:
    rig = pluggable
    session = await Session(rig).connect()
    try:
        await session.send(pose(rig.profile, 0.1))
        await session.shows(pose(rig.profile, 0.1))
        rig.unplug()
        meanwhile = pose(rig.profile, 0.3)
        for _ in range(10):  # as the control service would: no exception escapes
            await session.send(meanwhile)
            await asyncio.sleep(0.05)
        assert "disconnected" in session.driver.state()
        rig.plug()
        # The pose the driver holds (the last one sent) comes back without another command.
        await session.shows(meanwhile)
        await session.send(pose(rig.profile, 0.6))
        await session.shows(pose(rig.profile, 0.6))
        assert "disconnected" not in session.driver.state()
    finally:
        await session.close()


async def test_a_device_not_there_at_start_is_waited_for(pluggable: DriverRig) -> None:
    rig = pluggable
    rig.unplug()
    session = await Session(rig).connect()  # the service starts anyway
    try:
        wanted = pose(rig.profile, 0.5)
        await session.send(wanted)
        assert "disconnected" in session.driver.state()
        rig.plug()
        await session.shows(wanted)
    finally:
        await session.close()
