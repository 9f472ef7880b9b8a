"""ControlCore.check: a command checked on arrival (the service's screen) is not checked again
when :meth:`ControlCore.command` takes it, and nothing that passed before lets a bad one in."""

from __future__ import annotations

import math

import pytest

from facesynth.runtime.profiles import Profile, ServoSpec
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.core import Arrival, CommandError, ControlCore

PROFILE = Profile(
    name="rig",
    neutral_ramp_s=0.0,  # no catch-up: a command's targets are its positions at once
    servos=[
        ServoSpec(name="jaw", channel=0, min_us=1000, neutral_us=1500, max_us=2000),
        ServoSpec(name="brow", channel=1, min_us=900, neutral_us=1200, max_us=2100),
    ],
)
MS = 1_000_000


def _commands(seq: int, **positions: float) -> ServoCommands:
    return ServoCommands(
        seq=seq, t_capture_ns=seq, t_media_ns=seq, face=True, profile="rig", positions=positions
    )


def test_a_command_checked_on_arrival_moves_as_its_check_said() -> None:
    core = ControlCore(PROFILE)
    core.start(0)
    commands = _commands(1, jaw=2500.0, brow=1000.0)
    targets = core.check(commands)  # on arrival
    assert targets == {"jaw": 2000.0, "brow": 1000.0}
    targets["jaw"] = 1.0  # the caller's copy: the remembered verdict is not touched
    move, _ = core.command(commands, Arrival(10 * MS, 10 * MS))
    assert move.positions == {"jaw": 2000.0, "brow": 1000.0}
    assert core.check(commands) == {"jaw": 2000.0, "brow": 1000.0}


@pytest.mark.parametrize(
    ("bad", "detail"),
    [
        (_commands(2, jaw=math.nan), "position of 'jaw' is nan"),
        (_commands(2, jaw=1500.0, tail=1500.0), "unknown servos for profile 'rig': ['tail']"),
        (
            ServoCommands(
                seq=2, t_capture_ns=2, t_media_ns=2, face=True, profile="other", positions={}
            ),
            "commands are for profile 'other'; this controller drives 'rig'",
        ),
    ],
    ids=["nan", "unknown-servo", "other-profile"],
)
def test_a_bad_command_after_a_good_one_is_still_refused(bad: ServoCommands, detail: str) -> None:
    core = ControlCore(PROFILE)
    core.start(0)
    good = _commands(1, jaw=1700.0)
    core.check(good)
    core.command(good, Arrival(10 * MS, 10 * MS))
    for _ in range(2):  # on arrival, then when taken
        with pytest.raises(CommandError) as info:
            core.check(bad)
        assert str(info.value) == detail
    with pytest.raises(CommandError):
        core.command(bad, Arrival(20 * MS, 20 * MS))
    assert core.positions == {"jaw": 1700.0, "brow": 1200.0}


def test_an_equal_command_of_its_own_is_checked_as_its_own() -> None:
    core = ControlCore(PROFILE)
    first, second = _commands(1, jaw=1800.0), _commands(1, jaw=1800.0)
    assert core.check(first) == core.check(second) == {"jaw": 1800.0}
    assert core.check(first) == {"jaw": 1800.0}  # the older one, no longer the last checked
