"""A control interface of one robot among several: it listens on its robot's command key only,
publishes what it applied on its robot's state key, and still refuses another profile."""

from __future__ import annotations

from pathlib import Path

from facesynth.runtime.clock import FakeClock
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.drivers.record import RecordConfig, RecordDriver, read_record
from facesynth.services.control.service import ControlService

PAPER16 = load_profile("paper16")


def commands(seq: int, profile: str = "paper16", jaw: float = 1800.0) -> ServoCommands:
    return ServoCommands(
        seq=seq, t_capture_ns=1, t_media_ns=1, face=True, profile=profile, positions={"jaw": jaw}
    )


async def test_a_robot_applies_its_own_commands_only(tmp_path: Path) -> None:
    out = tmp_path / "a.jsonl"
    control = ControlService(PAPER16, RecordDriver(RecordConfig(out=str(out))))
    async with StageRun(control.serve, service="control", robot="a", clock=FakeClock()) as run:
        await run.send("servo_commands", commands(1, jaw=1700.0), robot="a")
        await run.send("servo_commands", commands(2, jaw=1900.0), robot="b")  # another robot's
        await run.send("servo_commands", commands(3, jaw=1950.0))  # the single-robot key
        await run.send("servo_commands", commands(4, jaw=1800.0), robot="a")
        # What it applied of the commands (not its own start-up move)
        states = [s for s in run.on("servo_state") if s.message.move == "command"]
        assert [s.key for s in states] == [f"facesynth/{run.rig}/servo_state/a"] * 2
        assert [s.message.seq for s in states] == [1, 4]
        assert run.ctx.stats.received == 2 and run.ctx.stats.rejected == 0
    frames = [line.frame for line in read_record(out) if line.frame is not None]
    assert frames == [1, 4]


async def test_a_robot_still_refuses_another_profile_on_its_key() -> None:
    control = ControlService(PAPER16, RecordDriver(RecordConfig(out="/dev/null")))
    async with StageRun(control.serve, service="control", robot="a", clock=FakeClock()) as run:
        await run.send("servo_commands", commands(1, profile="head16"), robot="a")
        assert run.ctx.stats.rejected == 1
        assert [s.message.move for s in run.on("servo_state")] == ["start"]
