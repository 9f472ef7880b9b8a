"""Measured positions flow on: what a driver reads back from its servos (position, load,
temperature, a fault) goes out on ``…/servo_state`` beside the commanded positions, for every
move; drivers that read nothing leave the tables empty, and old messages still decode."""

from __future__ import annotations

import math
from collections.abc import Mapping

import msgspec
import pytest

from facesynth.runtime import codec
from facesynth.runtime.clock import FakeClock
from facesynth.runtime.profiles import Profile, ServoSpec
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import ServoDriver, ServoReading
from facesynth.services.control.service import ControlService

FACE = Profile(
    name="free",
    servos=[
        ServoSpec(name=n, channel=i, min_us=1000, neutral_us=1500, max_us=2000, feature="jaw_open")
        for i, n in enumerate(("jaw", "brow"))
    ],
)


class ReadingDriver(ServoDriver):
    """A test double of a smart-servo driver: each servo is read back halfway from where it
    was to where it was sent (the jaw hot and stalled, reporting an overload)."""

    moves_hardware = False

    def __init__(self) -> None:
        self.where = FACE.neutral_positions()
        self.broken = False

    async def connect(self) -> None:
        pass

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        self.where = {n: (self.where[n] + positions.get(n, self.where[n])) / 2 for n in self.where}

    async def close(self) -> None:
        pass

    def readings(self) -> Mapping[str, ServoReading]:
        if self.broken:
            raise RuntimeError("a bug in the driver")
        return {
            "jaw": ServoReading(self.where["jaw"], 0.9, 71.0, "overload"),
            "brow": ServoReading(self.where["brow"], -0.1),
            "ghost": ServoReading(math.nan),  # never published
        }


async def test_servo_state_carries_the_readings_beside_the_commands() -> None:
    clock = FakeClock()
    driver = ReadingDriver()
    run = StageRun(ControlService(FACE, driver).serve, service="control", clock=clock)
    async with run:
        await run.send("servo_commands", command(1, jaw=1500.0, brow=1500.0))
        await run.advance(0.5)  # caught up at neutral
        await run.send("servo_commands", command(2, jaw=1800.0, brow=1500.0))
        state = run.messages("servo_state")[-1]
        assert state.seq == 2 and state.positions["jaw"] > 1500.0
        assert state.measured == {"jaw": driver.where["jaw"], "brow": 1500.0}
        assert 1500.0 < state.measured["jaw"] < state.positions["jaw"]  # on its way there
        assert state.loads == {"jaw": 0.9, "brow": -0.1}
        assert state.temperatures_c == {"jaw": 71.0}
        assert state.faults == {"jaw": "overload"}
        assert codec.decode(codec.encode(state), ServoCommands) == state
        driver.broken = True  # a driver that fails to read: the state goes out without
        await run.send("servo_commands", command(3, jaw=1700.0, brow=1500.0))
        state = run.messages("servo_state")[-1]
        assert state.seq == 3 and state.measured == {} and state.faults == {}


def command(seq: int, **positions: float) -> ServoCommands:
    return ServoCommands(
        seq=seq, t_capture_ns=1, t_media_ns=1, face=True, profile="free", positions=positions
    )


def test_messages_without_readings_decode_and_old_readers_skip_them() -> None:
    class OldServoCommands(msgspec.Struct, tag="servo_commands", tag_field="type", kw_only=True):
        seq: int
        t_capture_ns: int
        t_media_ns: int
        face: bool
        profile: str
        positions: dict[str, float]

    old = msgspec.msgpack.encode(OldServoCommands(**_fields(command(1, jaw=1500.0))))
    decoded = codec.decode(old, ServoCommands)
    assert decoded.measured == {} and decoded.faults == {} and decoded.loads == {}
    new = codec.encode(msgspec.structs.replace(command(2, jaw=1500.0), measured={"jaw": 1490.0}))
    assert msgspec.msgpack.decode(new, type=OldServoCommands).positions == {"jaw": 1500.0}


def _fields(message: ServoCommands) -> dict[str, object]:
    names = ("seq", "t_capture_ns", "t_media_ns", "face", "profile", "positions")
    return {name: getattr(message, name) for name in names}


@pytest.mark.parametrize(
    ("change", "error"),
    [
        ({"measured": {"jaw": math.inf}}, "measured position 'jaw'"),
        ({"loads": {"jaw": 3.0}}, "load 'jaw'"),
        ({"temperatures_c": {"jaw": math.nan}}, "temperature 'jaw'"),
        ({"faults": {"jaw": "over\nload"}}, "the fault of 'jaw' is not one line"),
    ],
)
def test_implausible_readings_are_refused(change: dict[str, object], error: str) -> None:
    message = msgspec.structs.replace(command(1, jaw=1500.0), **change)
    with pytest.raises(codec.MessageError, match=error):
        codec.decode(msgspec.msgpack.encode(message), ServoCommands)
