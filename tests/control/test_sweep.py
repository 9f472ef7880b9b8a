"""facesynth.services.control.sweep: the bring-up sweep, as steps."""

from __future__ import annotations

import itertools

import pytest

from facesynth.runtime.profiles import ServoSpec
from facesynth.services.control.sweep import sweep


def spec(**limits: float) -> ServoSpec:
    return ServoSpec(
        name="jaw", channel=11, **{"min_us": 1000, "neutral_us": 1400, "max_us": 2000, **limits}
    )


def test_neutral_to_each_limit_and_back_never_faster_than_asked() -> None:
    steps = sweep(spec(), speed_us_s=1000, rate_hz=50, hold_s=0.1)
    positions = [1400.0] + [s.position for s in steps]
    assert max(abs(b - a) for a, b in itertools.pairwise(positions)) <= 1000 / 50 + 1e-9
    arrivals = [(s.leg, s.position) for s in steps if s.arrived]
    assert arrivals == [
        ("min", 1000),
        ("hold min", 1000),
        ("neutral", 1400),
        ("max", 2000),
        ("hold max", 2000),
        ("neutral", 1400),
    ]
    assert len([s for s in steps if s.leg == "hold min"]) == 5  # 0.1 s at 50 Hz
    assert len([s for s in steps if s.leg == "min"]) == 20  # 400 us at 20 us per step
    assert all(1000 <= s.position <= 2000 for s in steps)


def test_a_servo_at_a_limit_and_no_hold() -> None:
    steps = sweep(spec(neutral_us=1000), speed_us_s=500, rate_hz=10, hold_s=0)
    assert [s.leg for s in steps if s.arrived] == ["min", "neutral", "max", "neutral"]
    assert steps[0].position == 1000  # already there: one step


@pytest.mark.parametrize(
    ("speed", "rate", "hold"),
    [(0, 50, 0), (-5, 50, 0), (float("nan"), 50, 0), (100, 0, 0), (100, 50, -1)],
)
def test_bad_speeds_rates_and_holds(speed: float, rate: float, hold: float) -> None:
    with pytest.raises(ValueError):
        sweep(spec(), speed, rate, hold)
