"""The last check before the driver writes (issue 28): a command's capture is judged again as
its move is handed to the driver, and one that grew too old since it was taken is withdrawn,
as if it never came: the face holds, then the watchdog returns it to neutral.

The core (``ControlCore.hand_over``) in pure virtual time, checked against a twin core that
never saw the withdrawn command; then the shell on a fake clock on which the process can lose
time between two of its own lines (a loaded machine descheduling it, a GC pause).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping

import msgspec
import pytest

from facesynth.runtime.clock import FakeClock
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.profiles import Profile, ServoSpec
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.core import Arrival, CommandInfo, ControlCore, Move
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.freshness import StaleCapture
from facesynth.services.control.service import ControlService

MS = 1_000_000
S = 1_000_000_000
HOST = "board"
#: The jaw is speed-limited, the brow catches up over neutral_ramp_s (no max_speed).
PROFILE = Profile(
    name="rig",
    servos=[
        ServoSpec(
            name="jaw",
            channel=0,
            min_us=1000,
            neutral_us=1500,
            max_us=2000,
            max_speed=2000.0,
            feature="jaw_open",
        ),
        ServoSpec(
            name="brow", channel=1, min_us=1000, neutral_us=1500, max_us=2000, feature="jaw_open"
        ),
    ],
)


def command(seq: int, captured_ns: int, sender: str = "t-1", **positions: float) -> ServoCommands:
    """Command ``seq`` of ``sender`` for a frame captured at ``captured_ns`` on this host."""
    return ServoCommands(
        seq=seq,
        t_capture_ns=captured_ns,
        t_media_ns=seq * 33 * MS,
        face=True,
        profile="rig",
        positions=positions,
        sender=sender,
        sender_seq=seq,
        sent_ns=captured_ns + 10 * MS,
        sender_host=HOST,
        capture_host=HOST,
    )


def take(core: ControlCore, commands: ServoCommands, t_ns: int) -> Move:
    """``commands`` taken from the queue at ``t_ns`` (wall and monotonic alike)."""
    move, _ = core.command(commands, Arrival(wall_ns=t_ns, mono_ns=t_ns, taken_ns=t_ns))
    return move


def started() -> ControlCore:
    core = ControlCore(PROFILE, own_host=HOST)
    core.start(0)
    return core


def test_a_command_in_time_at_the_hand_over_is_kept() -> None:
    core = started()
    move = take(core, command(1, 100 * MS, jaw=1900.0), 120 * MS)
    assert move.deadline_ns == 350 * MS
    core.hand_over(move, 350 * MS)  # just within: 0.25 s from capture
    assert core.positions == move.positions and core.late == 0


def test_a_command_too_old_at_the_hand_over_is_withdrawn_as_if_it_never_came() -> None:
    core, twin = started(), started()
    for each in (core, twin):
        first = take(each, command(1, 100 * MS, jaw=1900.0, brow=1800.0), 110 * MS)
        each.hand_over(first, 110 * MS)
    # Another translator's command, young when taken, 0.3 s from capture at the hand-over.
    late = take(core, command(1, 130 * MS, "t-2", jaw=1000.0, brow=1000.0), 140 * MS)
    with pytest.raises(StaleCapture, match=r"frame 1 was 0\.300 s from capture") as refused:
        core.hand_over(late, 430 * MS)
    assert "its turn at the driver came (limit 0.25 s): not executed" in refused.value.note
    assert core.late == 1
    assert core.positions == twin.positions and core.targets == twin.targets
    assert core.due_ns() == twin.due_ns()  # the watchdog counts from the command kept
    # From here the core goes on exactly as its twin: the same steps, the new sender's
    # catch-up included (the withdrawn command did not make "t-2" the sender followed).
    for t in (450 * MS, 483 * MS, 516 * MS):
        moves = [take(each, command(2 + t // MS, t - 20 * MS, "t-2", jaw=1000.0), t)
                 for each in (core, twin)]  # fmt: skip
        assert moves[0].positions == moves[1].positions
        core.hand_over(moves[0], t)
    assert core.tick(2 * S) == twin.tick(2 * S)  # and the watchdog's return


def test_a_run_of_late_commands_is_said_once() -> None:
    core = started()
    notes = []
    for i in range(3):
        t = (100 + 33 * i) * MS
        move = take(core, command(i + 1, t, jaw=1600.0), t + 5 * MS)
        with pytest.raises(StaleCapture) as refused:
            core.hand_over(move, t + 260 * MS)
        notes.append(refused.value.note)
    assert notes[0] and notes[1:] == ["", ""]
    kept = take(core, command(9, S, jaw=1600.0), S + 5 * MS)
    core.hand_over(kept, S + 5 * MS)
    late = take(core, command(10, 2 * S, jaw=1600.0), 2 * S)
    with pytest.raises(StaleCapture) as refused:
        core.hand_over(late, 2 * S + 300 * MS)
    assert refused.value.note  # a new run


def test_only_the_last_command_s_move_can_be_withdrawn() -> None:
    core = started()
    first = take(core, command(1, 100 * MS, jaw=1600.0), 100 * MS)
    take(core, command(2, 133 * MS, jaw=1700.0), 133 * MS)
    with pytest.raises(RuntimeError, match="only the last command's move"):
        core.hand_over(first, S)


# --- the shell: the clock read on the last line before the driver's send ------------------


class Descheduled(FakeClock):
    """Virtual time in which the process can lose time between two lines of its own, as a
    loaded machine deschedules it: :meth:`lose` moves both clocks at once, waking no one."""

    def __init__(self) -> None:
        super().__init__()
        self.lost_ns = 0

    def time_ns(self) -> int:
        return super().time_ns() + self.lost_ns

    def monotonic_ns(self) -> int:
        return super().monotonic_ns() + self.lost_ns

    def lose(self, seconds: float) -> None:
        self.lost_ns += round(seconds * 1e9)


class SlowDriver(ServoDriver):
    """Keeps what it was sent; a write of frame ``slow_frame`` takes ``slow_s``."""

    moves_hardware = False

    def __init__(self, clock: FakeClock, slow_frame: int = -1, slow_s: float = 0.0) -> None:
        self.clock = clock
        self.slow_frame, self.slow_s = slow_frame, slow_s
        self.sent: list[tuple[dict[str, float], CommandInfo]] = []

    async def connect(self) -> None:
        pass

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        self.sent.append((dict(positions), info))
        if info.frame == self.slow_frame:
            await self.clock.sleep(self.slow_s)

    async def close(self) -> None:
        pass

    def frames(self) -> list[int | None]:
        return [info.frame for _, info in self.sent]


def on_this_host(seq: int, captured_ns: int, **positions: float) -> ServoCommands:
    here = clock_host()
    commands = command(seq, captured_ns, **positions)
    return msgspec.structs.replace(commands, sender_host=here, capture_host=here)


async def test_a_command_that_loses_its_time_before_the_driver_is_not_executed(
    caplog: pytest.LogCaptureFixture,
) -> None:
    clock = Descheduled()
    driver = SlowDriver(clock)
    control = ControlService(PROFILE, driver, watchdog_s=0.5)
    taken = control.core.command

    def descheduled_after_frame_2(commands: ServoCommands, arrival: Arrival):  # type: ignore[no-untyped-def]
        decided = taken(commands, arrival)
        if commands.seq == 2:  # decided in time, then 300 ms without the CPU
            clock.lose(0.3)
        return decided

    control.core.command = descheduled_after_frame_2  # type: ignore[method-assign]
    run = StageRun(control.serve, service="control", clock=clock)
    caplog.set_level(logging.WARNING)
    async with run:
        await run.send("servo_commands", on_this_host(1, clock.time_ns() - 10 * MS, jaw=1600.0))
        assert driver.frames()[-1] == 1
        kept_at = clock.monotonic_ns()
        await run.send("servo_commands", on_this_host(2, clock.time_ns() - 10 * MS, jaw=2000.0))
        assert 2 not in driver.frames(), "a command 0.31 s from capture reached the driver"
        assert max(positions["jaw"] for positions, _ in driver.sent) <= 1600.0  # frame 1's
        assert (run.ctx.stats.stale, run.ctx.stats.rejected) == (1, 0)
        assert [m.seq for m in run.messages("servo_state") if m.move == "command"] == [1]
        said = [
            r.message for r in caplog.records if "when its turn at the driver came" in r.message
        ]
        assert len(said) == 1 and "0.310 s from capture" in said[0]

        # The face holds, then the watchdog (counting from frame 1) takes it back to neutral.
        def returns() -> list[int]:
            return [p.t_ns for p in run.on("servo_state") if p.message.move == "return"]

        await run.run_until(lambda: bool(returns()), 1.0)
        assert kept_at + 500 * MS < returns()[0] < kept_at + 600 * MS  # not from frame 2's
        await run.run_until(lambda: driver.sent[-1][0] == PROFILE.neutral_positions(), 2.0)
        await run.send("servo_commands", on_this_host(3, clock.time_ns() - 10 * MS, jaw=1600.0))
        assert driver.sent[-1][1].frame == 3  # in time again: executed
    assert run.messages("stats")[-1].stale == 1


async def test_a_command_that_waited_behind_a_slow_driver_write_is_not_executed() -> None:
    clock = FakeClock()
    driver = SlowDriver(clock, slow_frame=1, slow_s=0.4)  # a write that blocks for 0.4 s
    control = ControlService(PROFILE, driver, watchdog_s=0.5)
    run = StageRun(control.serve, service="control", clock=clock)
    async with run:
        await run.send("servo_commands", on_this_host(1, clock.time_ns() - 10 * MS, jaw=1600.0))
        await run.send("servo_commands", on_this_host(2, clock.time_ns() - 10 * MS, jaw=2000.0))
        await run.advance(0.5)
        assert 2 not in driver.frames()
        assert run.ctx.stats.stale == 1
