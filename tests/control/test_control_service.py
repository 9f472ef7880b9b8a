"""services.control.service in virtual time: clamping, rejecting, speed limits, the watchdog's
return to neutral, shutdown and what is reported on …/servo_state.

Every time below is exact: the shell runs on a FakeClock (facesynth.runtime.testing.StageRun).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import msgspec
import pytest

from facesynth.runtime.clock import FakeClock
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.profiles import Profile, ServoSpec, load_profile
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.core import MAX_STEP_S, CommandInfo
from facesynth.services.control.drivers.base import DriverError, ServoDriver
from facesynth.services.control.service import RAMP_RATE_HZ, ControlService

MS = 1_000_000
PAPER16 = load_profile("paper16")  # neutral 1500 µs everywhere, max_speed 2500-6000 µs/s
NEUTRAL16 = PAPER16.neutral_positions()
FREE = Profile(  # no speed limits (servos catch up over neutral_ramp_s after a start)
    name="free",
    servos=[
        ServoSpec(
            name=name, channel=i, min_us=1000, neutral_us=1500, max_us=2000, feature="jaw_open"
        )
        for i, name in enumerate(("jaw", "right_eyebrow", "left_eyebrow"))
    ],
)
NEUTRAL = FREE.neutral_positions()
STEPS = round(FREE.neutral_ramp_s * RAMP_RATE_HZ)


class ListDriver(ServoDriver):
    """Keeps what it was sent and when (a test double at the driver seam)."""

    moves_hardware = False

    def __init__(self, clock: FakeClock) -> None:
        self.clock = clock
        self.sent: list[tuple[int, dict[str, float], CommandInfo]] = []
        self.events: list[str] = []

    async def connect(self) -> None:
        self.events.append("connect")

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        assert self.events[0] == "connect" and "close" not in self.events, "not connected"
        self.sent.append((self.clock.monotonic_ns(), dict(positions), info))

    async def neutral(self, positions: Mapping[str, float]) -> None:
        self.events.append("neutral")
        await self.send(positions, CommandInfo(None, None, False))

    async def close(self) -> None:
        self.events.append("close")

    def own(self) -> list[tuple[int, dict[str, float]]]:
        """Sends made by the controller itself (not for a frame), after the start-up neutral."""
        return [(t, positions) for t, positions, info in self.sent[1:] if info.frame is None]


def commands(seq: int, profile: str = "free", **positions: float) -> ServoCommands:
    return ServoCommands(
        seq=seq, t_capture_ns=1, t_media_ns=1, face=True, profile=profile, positions=positions
    )


def control_run(
    profile: Profile = FREE, watchdog_s: float = 0.5, **options: object
) -> tuple[StageRun, ListDriver]:
    clock = FakeClock()
    driver = ListDriver(clock)
    control = ControlService(profile, driver, watchdog_s=watchdog_s, **options)  # type: ignore[arg-type]
    return StageRun(control.serve, service="control", clock=clock), driver


async def settle_catch_up(run: StageRun) -> None:
    """One neutral command: the start-up catch-up of servos without max_speed is over."""
    await run.send("servo_commands", commands(0, jaw=1500.0))


async def test_starts_at_neutral_and_applies_clamped_commands() -> None:
    run, driver = control_run()
    async with run:
        assert run.alive() and driver.events == ["connect", "neutral"]
        assert driver.sent == [(0, NEUTRAL, CommandInfo(None, None, False))]
        await settle_catch_up(run)
        await run.advance(0.2)
        await run.send("servo_commands", commands(1, jaw=2600.0, right_eyebrow=900.0))
        expected = {**NEUTRAL, "jaw": 2000.0, "right_eyebrow": 1000.0}
        wall = run.clock.time_ns()  # the step's wall-clock time goes to the driver too
        assert driver.sent[-1] == (200 * MS, expected, CommandInfo(1, 1, True, wall))
        applied = [p for p in run.on("servo_state") if p.message.move == "command"]
        assert [(p.t_ns, p.message.seq, p.message.positions) for p in applied][-1] == (
            200 * MS,
            1,
            expected,
        )
        assert run.ctx.stats.published == 2  # commands applied, not the controller's own moves


async def test_commands_are_stepped_within_each_servo_s_limits() -> None:
    run, driver = control_run(PAPER16, watchdog_s=5.0)
    async with run:
        await run.advance(0.1)
        await run.send("servo_commands", commands(0, "paper16", right_eyebrow=2000.0, jaw=2000.0))
        first = driver.sent[-1][1]
        assert first["right_eyebrow"] == pytest.approx(1500.0 + 3000 * MAX_STEP_S)  # 0.1 s → 40 ms
        await run.advance(1.0)
        timeline = [(t, p) for t, p, _ in driver.sent]
        assert timeline[-1][1]["jaw"] == 2000.0 and timeline[-1][1]["right_eyebrow"] == 2000.0
        for (t0, a), (t1, b) in itertools.pairwise(timeline):
            for spec in PAPER16.servos:
                assert abs(b[spec.name] - a[spec.name]) <= spec.max_speed * (t1 - t0) / 1e9 + 1e-6
        states = run.messages("servo_state")
        assert {s.move for s in states} == {"start", "command", "catch-up", "report"}
        assert all(s.seq == 0 for s in states if s.move == "catch-up")


async def test_refuses_bad_commands_whole_and_counts_them() -> None:
    run, driver = control_run()
    async with run:
        await run.send("servo_commands", commands(0, tail=1500.0))  # unknown servo
        await run.send("servo_commands", commands(1, profile="other", jaw=1600.0))
        await run.send("servo_commands", b"\x93garbage")
        await run.send("servo_commands", commands(2, jaw=float("nan")))
        assert run.ctx.stats.rejected == 4 and run.ctx.stats.received == 4
        assert len(driver.sent) == 1
        assert [s.move for s in run.messages("servo_state")] == ["start"]


@pytest.mark.parametrize("in_process", [False, True], ids=["bytes", "object"])
async def test_every_command_is_checked_and_clamped_whatever_path_it_took(in_process: bool) -> None:
    # A stage of the same process hands C the message object, never encoded nor decoded: C
    # refuses and clamps exactly as it does for bytes from another process.
    run, driver = control_run()
    async with run:

        async def send(message: ServoCommands) -> None:
            await run.send("servo_commands", message, in_process=in_process)

        await send(commands(0, jaw=1500.0))  # the start-up catch-up is over
        await run.advance(0.2)
        await send(commands(1, jaw=2600.0, right_eyebrow=900.0))
        assert driver.sent[-1][1] == {**NEUTRAL, "jaw": 2000.0, "right_eyebrow": 1000.0}
        moved = len(driver.sent)
        await send(commands(2, tail=1500.0))  # unknown servo
        await send(commands(3, profile="other", jaw=1600.0))
        await send(commands(4, jaw=float("nan")))
        await send(commands(5, jaw=float("inf")))
        await send(commands(6, jaw=-5.0))
        await send(commands(7, jaw="1600"))  # type: ignore[arg-type]  # not a number
        await send(msgspec.structs.replace(commands(8, jaw=1600.0), sender=["not", "a name"]))
        assert run.ctx.stats.rejected == 7 and run.ctx.stats.received == 9
        assert len(driver.sent) == moved, "nothing moved"


async def test_silence_ramps_to_neutral_reaching_it_exactly_after_watchdog_plus_ramp() -> None:
    run, driver = control_run(watchdog_s=0.5)
    async with run:
        await run.advance(1.0)
        assert len(driver.sent) == 1, "no command yet: nothing to return from"
        await settle_catch_up(run)
        await run.send("servo_commands", commands(1, jaw=2000.0))  # last command at t = 1.0 s
        await run.advance(0.5 - 1e-9)
        assert driver.own() == [], "the watchdog must not fire before 0.5 s of silence"
        await run.advance(2.0)
        ramp = driver.own()
        # Step i of STEPS at 1.0 + 0.5 + i * 0.5 / STEPS: the last one, neutral, at exactly 2.0 s.
        assert [t for t, _ in ramp] == [1500 * MS + i * 500 * MS // STEPS for i in range(1, 13)]
        assert ramp[-1] == (2000 * MS, NEUTRAL)
        jaw = [positions["jaw"] for _, positions in ramp]
        assert jaw == pytest.approx([2000.0 - 500.0 * i / STEPS for i in range(1, STEPS + 1)])
        assert all(p["right_eyebrow"] == 1500.0 for _, p in ramp)
        await run.advance(60.0)
        assert driver.own() == ramp, "the watchdog fires once per silence"
        returns = [s for s in run.messages("servo_state") if s.move == "return"]
        assert len(returns) == STEPS and returns[-1].positions == NEUTRAL and returns[-1].seq == 1


async def test_a_command_interrupts_the_ramp_and_the_next_silence_ramps_from_there() -> None:
    run, driver = control_run(watchdog_s=0.5)
    async with run:
        await settle_catch_up(run)
        await run.send("servo_commands", commands(1, jaw=2000.0))
        await run.advance(0.5 + 4 * 0.5 / STEPS)  # four ramp steps in
        assert len(driver.own()) == 4
        await run.send("servo_commands", commands(2, left_eyebrow=1500.0))
        at_command = driver.sent[-1]
        assert at_command[2].frame == 2
        # Servos the command leaves out hold where the ramp had taken them.
        assert at_command[1]["jaw"] == pytest.approx(2000.0 - 500.0 * 4 / STEPS)
        await run.advance(0.5 - 1e-9)
        assert driver.sent[-1] == at_command, "the old ramp must not go on"
        await run.advance(1.0)
        second = [(t, p) for t, p in driver.own() if t > at_command[0]]
        assert second[-1][1] == NEUTRAL
        assert second[-1][0] == at_command[0] + 500 * MS + 500 * MS


async def test_commands_captured_too_long_ago_hold_then_return_to_neutral_said_once(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # Points stalled 3 s, then its backlog came through: the controller's own host captured
    # the frames (so they are aged from the first), the commands carry no send stamps.
    run, driver = control_run(watchdog_s=0.5)
    host = clock_host()

    def captured(seq: int, t_capture_ns: int, **positions: float) -> ServoCommands:
        command = commands(seq, **positions)
        return msgspec.structs.replace(command, t_capture_ns=t_capture_ns, capture_host=host)

    async with run:
        await settle_catch_up(run)
        await run.send("servo_commands", captured(1, run.clock.time_ns() - 10 * MS, jaw=1600.0))
        assert driver.sent[-1][2].frame == 1
        await run.advance(0.1)
        stall_start = run.clock.time_ns() - 3_000 * MS
        for i in range(3):
            await run.send("servo_commands", captured(2 + i, stall_start + i * 33 * MS, jaw=2000.0))
        assert driver.sent[-1][1]["jaw"] == 1600.0, "the backlog must not move the face"
        assert (run.ctx.stats.stale, run.ctx.stats.rejected, run.ctx.stats.received) == (3, 0, 5)
        said = [r.message for r in caplog.records if "dropping commands this old" in r.message]
        assert len(said) == 1 and "captured 3.00 s ago" in said[0]
        await run.advance(0.4 + 0.5)  # the watchdog counts from the last command applied
        assert driver.sent[-1][1] == NEUTRAL
        await run.send("servo_commands", captured(5, run.clock.time_ns() - 10 * MS, jaw=1700.0))
        assert driver.sent[-1][2].frame == 5  # fresh frames move the face again
        assert any("dropped 3 captured up to 3.00 s" in r.message for r in caplog.records)
    assert run.messages("stats")[-1].stale == 3


async def test_without_a_ramp_the_face_returns_to_neutral_at_once() -> None:
    run, driver = control_run(msgspec.structs.replace(FREE, neutral_ramp_s=0.0), watchdog_s=0.3)
    async with run:
        await run.send("servo_commands", commands(0, jaw=1900.0))
        assert driver.sent[-1][1]["jaw"] == 1900.0  # no catch-up either
        await run.advance(5.0)
        assert driver.own() == [(300 * MS, NEUTRAL)]


async def test_watchdog_counts_from_the_last_applied_command() -> None:
    run, driver = control_run(watchdog_s=0.5)
    async with run:
        await settle_catch_up(run)
        for i in range(5):  # a command every 0.4 s keeps the face where the commands say
            await run.send("servo_commands", commands(i + 1, jaw=1600.0 + i))
            await run.advance(0.4)
        assert driver.own() == []
        await run.run_until(lambda: bool(driver.own()), timeout=5.0)
        # Last command at 1.6 s: the watchdog fires at 2.1 s, the first step follows.
        assert driver.own()[0][0] == 2100 * MS + 500 * MS // STEPS == run.clock.monotonic_ns()


async def test_an_idle_controller_reports_where_the_face_is_twice_a_second() -> None:
    run, driver = control_run()
    async with run:
        await run.advance(2.0)
        reports = run.on("servo_state")
        assert [(p.t_ns, p.message.move) for p in reports] == [
            (0, "start"),
            *((i * 500 * MS, "report") for i in range(1, 5)),
        ]
        assert all(p.message.positions == NEUTRAL for p in reports)
        assert len(driver.sent) == 1, "a report moves nothing"


async def test_stopping_ramps_back_to_neutral_then_closes_the_driver() -> None:
    run, driver = control_run(PAPER16)
    await run.start()
    await run.send("servo_commands", commands(0, "paper16", jaw=1900.0, right_eye_x=2000.0))
    await run.advance(0.3)
    assert driver.sent[-1][1]["jaw"] == 1900.0
    await run.stop()  # the return to neutral runs on the fake clock
    assert driver.events == ["connect", "neutral", "neutral", "close"]  # at start and at stop
    last_t, last, _ = driver.sent[-1]
    assert last == NEUTRAL16
    ramp = [(t, p) for t, p, _ in driver.sent if t >= 300 * MS]
    assert len(ramp) > 5 and last_t - 300 * MS <= 0.5e9 + 0.2e9
    for (t0, a), (t1, b) in itertools.pairwise(ramp):
        for spec in PAPER16.servos:
            assert abs(b[spec.name] - a[spec.name]) <= spec.max_speed * (t1 - t0) / 1e9 + 1e-6
    assert not run.alive()
    assert run.messages("stats")[-1].note == "stopped"


async def test_in_media_time_a_shutdown_ramps_without_waiting() -> None:
    run, driver = control_run(PAPER16, motion_time="media")
    await run.start()
    await run.send("servo_commands", commands(0, "paper16", jaw=1600.0))
    await run.stop()
    assert driver.sent[-1][1] == NEUTRAL16 and driver.events[-1] == "close"
    assert {t for t, _, _ in driver.sent} == {0}  # no virtual time passed


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
