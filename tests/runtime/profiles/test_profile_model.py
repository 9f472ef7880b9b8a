"""runtime.profiles.model: defaults, servo lookup, the one-line description of a servo's source."""

from __future__ import annotations

from typing import Any

import pytest
from profile_toml import POINTS, feature_servo, points_toml, profile_toml

from facesynth.runtime.profiles import describe_source, load_profile, parse_profile


def test_minimal_profile_and_defaults() -> None:
    profile = parse_profile(points_toml())
    assert profile.name == "test"
    assert profile.mirror is False and profile.neutral_seconds == 1.0
    (servo,) = profile.servos
    assert servo.reversed is False and servo.description == ""
    assert (servo.min_us, servo.neutral_us, servo.max_us) == (1000, 1500, 2000)


def test_defaults_of_the_optional_fields() -> None:
    profile = parse_profile(profile_toml())
    (spec,) = profile.servos
    assert (spec.gain, spec.deadband, spec.max_speed, spec.max_accel) == (1.0, 0.0, 0.0, 0.0)
    assert spec.smoothing is None and spec.points == [] and spec.face_min is None
    assert profile.smoothing is None and profile.neutral_ramp_s == 0.5
    assert profile.safety.exclusive == []
    assert profile.smoothing_for(spec) is None


def test_servo_lookup() -> None:
    profile = load_profile("paper16")
    assert profile.servo("jaw").channel == 11
    with pytest.raises(KeyError):
        profile.servo("tail")


@pytest.mark.parametrize(
    ("servo", "expected"),
    [
        (feature_servo(), "feature jaw_open"),
        (feature_servo(**POINTS), "points [56, 57, 58]"),
        (
            feature_servo(points=[37], face_min=-0.1, face_max=0.1, max_speed=6000, deadband=0.05),
            "feature jaw_open; fallback points [37]; deadband 0.05; max_speed 6000",
        ),
        (
            feature_servo(
                feature=None, mix={"lip_corner_pull_right": 1.0, "lips_part": -0.5}, gain=2
            ),
            "mix +1 lip_corner_pull_right, -0.5 lips_part; gain 2",
        ),
    ],
    ids=["feature", "points", "fallback", "mix"],
)
def test_describe_source(servo: dict[str, Any], expected: str) -> None:
    assert describe_source(parse_profile(profile_toml([servo])).servos[0]) == expected
