"""facesynth.services.control.core: which commands reach the servos (checks). The watchdog and
the ramp that return them to neutral: test_control_neutral_return.py; motion, freshness and the
core's own moves: test_control_motion.py, test_control_freshness.py, test_control_moves.py."""

from __future__ import annotations

import math
from typing import Any

import msgspec
import pytest

from facesynth.runtime.profiles import Profile, ServoSpec
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.core import (
    Arrival,
    CommandError,
    CommandInfo,
    ControlCore,
)

PROFILE = Profile(
    name="rig",
    servos=[
        ServoSpec(
            name="jaw",
            channel=0,
            points=[57],
            min_us=1000,
            neutral_us=1500,
            max_us=2000,
            face_min=-0.1,
            face_max=0.1,
        ),
        ServoSpec(
            name="brow",
            channel=1,
            points=[19],
            min_us=900,
            neutral_us=1200,
            max_us=2100,
            face_min=-0.1,
            face_max=0.1,
        ),
        ServoSpec(
            name="lip",
            channel=2,
            points=[48],
            min_us=1100,
            neutral_us=1400,
            max_us=1700,
            face_min=-0.1,
            face_max=0.1,
            reversed=True,
        ),
    ],
)
NEUTRAL = {"jaw": 1500.0, "brow": 1200.0, "lip": 1400.0}


def _commands(positions: dict[str, float], **kw: Any) -> ServoCommands:
    fields: dict[str, Any] = dict(
        seq=1, t_capture_ns=2, t_media_ns=3, face=True, profile="rig", positions=positions
    )
    fields.update(kw)
    return ServoCommands(**fields)


INSTANT = msgspec.structs.replace(PROFILE, neutral_ramp_s=0.0)  # no limits, no catch-up
MS = 1_000_000


def _apply(core: ControlCore, commands: ServoCommands, t_ms: int = 0) -> dict[str, float]:
    move, _ = core.command(commands, Arrival(wall_ns=t_ms * MS, mono_ns=t_ms * MS))
    assert move.kind == "command"
    return move.positions


def test_starts_at_neutral() -> None:
    core = ControlCore(PROFILE)
    move = core.start(0)
    assert (move.kind, move.positions, move.send) == ("start", NEUTRAL, True)
    assert core.positions == NEUTRAL


@pytest.mark.parametrize(
    ("positions", "expected"),
    [
        (
            {"jaw": 1600.0, "brow": 1000.0, "lip": 1500.0},
            {"jaw": 1600.0, "brow": 1000.0, "lip": 1500.0},
        ),
        (
            {"jaw": 2500.0, "brow": 100.0, "lip": 1700.5},
            {"jaw": 2000.0, "brow": 900.0, "lip": 1700.0},
        ),
        ({"jaw": 999.999}, {"jaw": 1000.0, "brow": 1200.0, "lip": 1400.0}),
        ({"jaw": math.inf, "brow": -math.inf}, {"jaw": 2000.0, "brow": 900.0, "lip": 1400.0}),
        ({"brow": 2100.0}, {"jaw": 1500.0, "brow": 2100.0, "lip": 1400.0}),
        ({}, NEUTRAL),
    ],
    ids=[
        "inside",
        "clamped-each-to-its-own-limits",
        "just-below-min",
        "infinities",
        "only-one-servo",
        "empty",
    ],
)
def test_commands_are_clamped_and_filled_in(
    positions: dict[str, float], expected: dict[str, float]
) -> None:
    core = ControlCore(INSTANT)  # no speed limits: the positions arrive at once
    core.start(0)
    assert _apply(core, _commands(positions), 20) == expected
    assert core.positions == expected


def test_missing_servos_keep_their_last_value() -> None:
    core = ControlCore(INSTANT)
    core.start(0)
    _apply(core, _commands({"jaw": 1900.0, "brow": 1000.0, "lip": 1200.0}), 20)
    assert _apply(core, _commands({"brow": 2000.0}, seq=2), 40) == {
        "jaw": 1900.0,
        "brow": 2000.0,
        "lip": 1200.0,
    }
    assert _apply(core, _commands({}, seq=3), 60) == {"jaw": 1900.0, "brow": 2000.0, "lip": 1200.0}


@pytest.mark.parametrize(
    ("commands", "detail"),
    [
        (
            _commands({"jaw": 1600.0}, profile="paper16"),
            "commands are for profile 'paper16'; this controller drives 'rig'",
        ),
        (_commands({"jaw": 1600.0, "tail": 1500.0}), "unknown servos for profile 'rig': ['tail']"),
        (
            _commands({"zeta": 1.0, "alpha": 2.0}),
            "unknown servos for profile 'rig': ['alpha', 'zeta']",
        ),
        (
            _commands({f"s{i}": 1500.0 for i in range(4)}),
            "4 positions for a profile of 3 servos",
        ),
        (
            _commands({f"s{i}": 1500.0 for i in range(1_000)}),
            "1000 positions for a profile of 3 servos",
        ),
    ],
    ids=["other-profile", "one-unknown-servo", "unknown-servos-sorted", "one-too-many", "a-flood"],
)
def test_refused_commands_change_nothing(commands: ServoCommands, detail: str) -> None:
    core = ControlCore(INSTANT)
    core.start(0)
    before = _apply(core, _commands({"jaw": 1800.0, "brow": 950.0}), 20)
    with pytest.raises(CommandError) as info:
        core.command(commands, Arrival(40 * MS, 40 * MS))
    assert str(info.value) == detail
    assert core.positions == before  # refused whole, not half applied


@pytest.mark.parametrize("bad", [math.nan, -math.nan], ids=["nan", "minus-nan"])
def test_non_finite_position_never_reaches_a_servo(bad: float) -> None:
    # codec.decode refuses NaN on the wire, but the core promises "every position is clamped to
    # its servo's limits, whatever T computed": a NaN must not pass through clamp() unchanged.
    core = ControlCore(INSTANT)
    core.start(0)
    before = _apply(core, _commands({"jaw": 1800.0}), 20)
    with pytest.raises(CommandError, match="jaw"):
        core.command(_commands({"jaw": bad, "brow": 1000.0}), Arrival(40 * MS, 40 * MS))
    assert core.positions == before


def test_command_info_is_frozen() -> None:
    info = CommandInfo(frame=3, t_capture_ns=4, face=True)
    with pytest.raises(AttributeError):
        info.frame = 5  # type: ignore[misc]
