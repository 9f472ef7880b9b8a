"""The console's pure core: jog targets clamped to the limits C enforces and to the draft's,
limits set from where a servo stands, names and reversal, every refusal one clear message."""

from __future__ import annotations

import math

import msgspec
import pytest

from facesynth.app.console.rig import ConsoleError, ConsoleRig
from facesynth.runtime.profiles import load_profile

PROFILE = load_profile("head16_hardware")
FIRST = PROFILE.servos[0]


def _rig() -> ConsoleRig:
    return ConsoleRig(PROFILE)


def test_a_jog_holds_the_servos_and_is_clamped_to_the_limits() -> None:
    rig = _rig()
    assert not rig.holding
    assert rig.jog(0, 1700.0) == 1700.0
    assert rig.holding
    assert rig.jog(0, 99999.0) == FIRST.max_us
    assert rig.jog(0, -5.0) == FIRST.min_us
    commands = rig.commands()
    assert list(commands) == [spec.name for spec in PROFILE.servos]
    assert commands[FIRST.name] == FIRST.min_us


@pytest.mark.parametrize(
    ("servo", "us", "message"),
    [
        (99, 1500.0, "no servo 99: profile 'head16_hardware' has servos 0..15"),
        (-1, 1500.0, "no servo -1"),
        ("0", 1500.0, "a servo is given by its index, not '0'"),
        (True, 1500.0, "a servo is given by its index"),
        (0, math.nan, "a position must be a finite number of µs, not nan"),
        (0, math.inf, "not inf"),
    ],
)
def test_a_bad_jog_is_refused(servo: object, us: float, message: str) -> None:
    rig = _rig()
    with pytest.raises(ConsoleError, match=message.replace("(", r"\(").replace(")", r"\)")):
        rig.jog(servo, us)  # type: ignore[arg-type]
    assert rig.targets == [spec.neutral_us for spec in PROFILE.servos]


def test_limits_set_from_where_a_servo_stands_narrow_its_jog_at_once() -> None:
    rig = _rig()
    rig.report(PROFILE.name, {FIRST.name: 1234.0})
    assert rig.set_limit(0, "min") == 1234.0
    assert rig.draft.servos[0].min_us == 1234.0
    assert rig.active.servos[0].min_us == FIRST.min_us  # C keeps its limits until a save
    assert rig.dirty
    assert rig.jog(0, 1000.0) == 1234.0  # the draft's narrower limit holds now
    rig.report(PROFILE.name, {FIRST.name: 1800.0})
    rig.set_limit(0, "max")
    rig.set_limit(0, "neutral", 1500.0)
    assert rig.bounds(0) == (1234.0, 1800.0)


def test_a_widened_limit_waits_for_the_save() -> None:
    rig = _rig()
    rig.set_limit(0, "max", 2300.0)
    assert rig.jog(0, 2300.0) == FIRST.max_us  # C still runs the loaded limits
    saved = msgspec.structs.replace(rig.draft)
    rig.saved(saved)
    assert not rig.dirty
    assert rig.jog(0, 2300.0) == 2300.0


def test_read_back_positions_and_faults_are_kept_beside_the_commanded() -> None:
    rig = _rig()
    assert rig.read_back(0) == (None, "")  # a board that cannot read its servos back
    second = PROFILE.servos[1].name
    rig.report(
        PROFILE.name,
        {FIRST.name: 1600.0},
        measured={FIRST.name: 1588.0, second: 1500.0},
        faults={second: "overload"},
    )
    assert rig.here(0) == 1600.0 and rig.read_back(0) == (1588.0, "")
    assert rig.read_back(1) == (1500.0, "overload")
    rig.report(PROFILE.name, {FIRST.name: 1600.0})  # each report replaces the readings
    assert rig.read_back(0) == (None, "") and rig.read_back(1) == (None, "")


def test_reports_of_another_profile_are_ignored() -> None:
    rig = _rig()
    rig.report("paper16", {FIRST.name: 1111.0})
    assert rig.here(0) == FIRST.neutral_us


@pytest.mark.parametrize(
    ("which", "us", "message"),
    [
        ("min", 1600.0, "min_us"),  # above neutral: the profile's own validation says why
        ("max", 1400.0, "max_us"),
        ("middle", 1500.0, "a limit is min, neutral or max, not 'middle'"),
        ("min", math.nan, "a limit must be a finite number"),
    ],
)
def test_a_limit_that_breaks_the_profile_is_refused(which: str, us: float, message: str) -> None:
    rig = _rig()
    with pytest.raises(ConsoleError, match=message):
        rig.set_limit(0, which, us)  # type: ignore[arg-type]
    assert rig.draft == PROFILE
    assert not rig.dirty


def test_rename_and_reverse() -> None:
    rig = _rig()
    rig.rename(0, "  brow_r ")
    rig.reverse(0, True)
    assert rig.draft.servos[0].name == "brow_r"
    assert rig.draft.servos[0].reversed
    assert rig.commands()[FIRST.name] == FIRST.neutral_us  # C knows it by its old name
    with pytest.raises(ConsoleError, match="letters, digits"):
        rig.rename(1, "two words")
    with pytest.raises(ConsoleError, match="1 to 40"):
        rig.rename(1, "")
    with pytest.raises(ConsoleError, match="brow_r"):  # names are unique
        rig.rename(1, "brow_r")


def test_centre_neutral_and_stop() -> None:
    rig = _rig()
    rig.centre_all()
    assert rig.targets == [(s.min_us + s.max_us) / 2 for s in PROFILE.servos]
    rig.jog(0, 1900.0)
    rig.neutral_all()
    assert rig.targets == [s.neutral_us for s in PROFILE.servos]
    rig.jog(0, 1900.0)
    rig.report(PROFILE.name, {FIRST.name: 1620.0})  # still on its way
    rig.stop_all()
    assert rig.targets[0] == 1620.0 and rig.holding
    rig.release()
    assert not rig.holding


def test_a_learned_profile_is_not_edited() -> None:
    learned = msgspec.structs.replace(PROFILE, learned=object())  # any fitted mapping
    with pytest.raises(ConsoleError, match="is learned"):
        ConsoleRig(learned)
