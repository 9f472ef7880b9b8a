"""services.control.service in virtual time: clamping, rejecting, the watchdog and the neutral ramp.

Every time below is exact: the shell runs on a FakeClock (facesynth.runtime.testing.StageRun).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import msgspec
import pytest

from facesynth.runtime.clock import FakeClock
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.runtime.testing import StageRun
from schemas.messages import ServoCommands
from services.control.core import CommandInfo
from services.control.drivers.base import DriverError, ServoDriver
from services.control.service import RAMP_RATE_HZ, ControlService

MS = 1_000_000
PAPER16 = load_profile("paper16")  # neutral 1500 µs everywhere, neutral_ramp_s 0.5
NEUTRAL = PAPER16.neutral_positions()
STEPS = round(PAPER16.neutral_ramp_s * RAMP_RATE_HZ)


class ListDriver(ServoDriver):
    """Keeps what it was sent and when (a test double at the driver seam)."""

    def __init__(self, clock: FakeClock) -> None:
        self.clock = clock
        self.sent: list[tuple[int, dict[str, float], CommandInfo]] = []
        self.events: list[str] = []

    async def connect(self) -> None:
        self.events.append("connect")

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        assert self.events[-1] == "connect", "sent to a driver that is not connected"
        self.sent.append((self.clock.monotonic_ns(), dict(positions), info))

    async def close(self) -> None:
        self.events.append("close")

    def ramp(self) -> list[tuple[int, dict[str, float]]]:
        """Sends made by the controller itself (not for a frame), after the start-up neutral."""
        return [(t, positions) for t, positions, info in self.sent[1:] if info.frame is None]


def commands(seq: int, profile: str = "paper16", **positions: float) -> ServoCommands:
    return ServoCommands(
        seq=seq, t_capture_ns=1, t_media_ns=1, face=True, profile=profile, positions=positions
    )


def control_run(profile: Profile = PAPER16, watchdog_s: float = 0.5) -> tuple[StageRun, ListDriver]:
    clock = FakeClock()
    driver = ListDriver(clock)
    control = ControlService(profile, driver, watchdog_s=watchdog_s)
    return StageRun(control.serve, service="control", clock=clock), driver


async def test_starts_at_neutral_and_applies_clamped_commands_at_once() -> None:
    run, driver = control_run()
    async with run:
        assert run.alive() and driver.events == ["connect"]
        assert driver.sent == [(0, NEUTRAL, CommandInfo(None, None, False))]
        await run.advance(0.2)
        await run.send("servo_commands", commands(0, jaw=2600.0, right_eyebrow=900.0))
        expected = {**NEUTRAL, "jaw": 2000.0, "right_eyebrow": 1000.0}
        assert driver.sent[-1] == (200 * MS, expected, CommandInfo(0, 1, True))
        [state] = run.on("servo_state")
        assert state.t_ns == 200 * MS
        assert (state.message.seq, state.message.positions) == (0, expected)


async def test_refuses_bad_commands_whole_and_counts_them() -> None:
    run, driver = control_run()
    async with run:
        await run.send("servo_commands", commands(0, tail=1500.0))  # unknown servo
        await run.send("servo_commands", commands(1, profile="other", jaw=1600.0))
        await run.send("servo_commands", b"\x93garbage")
        await run.send("servo_commands", commands(2, jaw=float("nan")))
        assert run.ctx.stats.rejected == 4 and run.ctx.stats.received == 4
        assert len(driver.sent) == 1 and run.messages("servo_state") == []


async def test_silence_ramps_to_neutral_reaching_it_exactly_after_watchdog_plus_ramp() -> None:
    run, driver = control_run(watchdog_s=0.5)
    async with run:
        await run.advance(1.0)  # no command yet: nothing to return from
        assert len(driver.sent) == 1
        await run.send("servo_commands", commands(0, jaw=2000.0))  # last command at t = 1.0 s
        await run.advance(0.5 - 1e-9)
        assert driver.ramp() == [], "the watchdog must not fire before 0.5 s of silence"
        await run.advance(2.0)
        ramp = driver.ramp()
        # Step i of STEPS at 1.0 + 0.5 + i * 0.5 / STEPS: the last one, neutral, at exactly 2.0 s.
        assert [t for t, _ in ramp] == [1500 * MS + i * 500 * MS // STEPS for i in range(1, 13)]
        assert ramp[-1] == (2000 * MS, NEUTRAL)
        jaw = [positions["jaw"] for _, positions in ramp]
        assert jaw == pytest.approx([2000.0 - 500.0 * i / STEPS for i in range(1, STEPS + 1)])
        assert all(a > b for a, b in itertools.pairwise(jaw))
        # The other servos were at neutral already and stay there.
        assert all(p["right_eyebrow"] == 1500.0 for _, p in ramp)
        await run.advance(60.0)
        assert driver.ramp() == ramp, "the watchdog fires once per silence"


async def test_a_command_interrupts_the_ramp_and_the_next_silence_ramps_from_there() -> None:
    run, driver = control_run(watchdog_s=0.5)
    async with run:
        await run.send("servo_commands", commands(0, jaw=2000.0))
        await run.advance(0.5 + 0.2)  # four ramp steps in (the fourth at 0.5 + 4 * 0.5 / 12 s)
        assert len(driver.ramp()) == 4
        await run.send("servo_commands", commands(1, left_eyebrow=1800.0))
        at_command = driver.sent[-1]
        assert at_command[0] == 700 * MS and at_command[2].frame == 1
        # Servos the command leaves out hold where the ramp had taken them.
        assert at_command[1]["jaw"] == pytest.approx(2000.0 - 500.0 * 4 / STEPS)
        await run.advance(0.5 - 1e-9)
        assert driver.sent[-1] == at_command, "the old ramp must not go on"
        await run.advance(1.0)
        second = [(t, p) for t, p in driver.ramp() if t > 700 * MS]
        assert second[0][0] == 1200 * MS + 500 * MS // STEPS and second[-1] == (1700 * MS, NEUTRAL)
        assert second[0][1]["left_eyebrow"] == pytest.approx(1800.0 - 300.0 / STEPS)


async def test_without_a_ramp_the_face_returns_to_neutral_at_once() -> None:
    run, driver = control_run(msgspec.structs.replace(PAPER16, neutral_ramp_s=0.0), watchdog_s=0.3)
    async with run:
        await run.send("servo_commands", commands(0, jaw=1900.0))
        await run.advance(5.0)
        assert driver.ramp() == [(300 * MS, NEUTRAL)]


async def test_watchdog_counts_from_the_last_applied_command() -> None:
    run, driver = control_run(watchdog_s=0.5)
    async with run:
        for i in range(5):  # a command every 0.4 s keeps the face where the commands say
            await run.send("servo_commands", commands(i, jaw=1600.0 + i))
            await run.advance(0.4)
        assert driver.ramp() == []
        await run.run_until(lambda: bool(driver.ramp()), timeout=5.0)
        # Last command at 1.6 s: the watchdog fires at 2.1 s, the first step follows.
        assert driver.ramp()[0][0] == 2100 * MS + 500 * MS // STEPS == run.clock.monotonic_ns()


async def test_stopping_returns_to_neutral_then_closes_the_driver() -> None:
    run, driver = control_run()
    await run.start()
    await run.send("servo_commands", commands(0, jaw=1900.0))
    await run.advance(0.1)
    await run.stop()
    assert driver.events == ["connect", "close"]
    assert driver.sent[-1][1] == NEUTRAL and driver.sent[-1][0] == 100 * MS
    assert not run.alive()
    assert run.messages("stats")[-1].note == "stopped"


class FailingDriver(ListDriver):
    async def connect(self) -> None:
        raise DriverError("no board")


async def test_a_driver_that_cannot_connect_stops_the_service_without_moving() -> None:
    clock = FakeClock()
    driver = FailingDriver(clock)
    run = StageRun(ControlService(PAPER16, driver).serve, service="control", clock=clock)
    await run.start()
    with pytest.raises(DriverError, match="no board"):
        await run.stop()
    assert driver.sent == [] and driver.events == []
