"""runtime.profiles.model.AngleMap: each servo's pulse -> joint angle map (the ros2 driver's
radians), its hobby-servo default and the one-line problems of a wrong one."""

from __future__ import annotations

import math

import pytest
from profile_toml import feature_servo, profile_toml

from facesynth.runtime.profiles import AngleMap, ProfileError, load_profile, parse_profile


def test_the_default_is_500_to_2500_us_over_0_to_180_degrees() -> None:
    spec = parse_profile(profile_toml([feature_servo()])).servos[0]
    assert spec.angle == AngleMap(min_us=500, max_us=2500, min_deg=0, max_deg=180)
    assert spec.angle.radians(500) == 0.0
    assert spec.angle.radians(1500) == pytest.approx(math.pi / 2)
    assert spec.angle.radians(2500) == pytest.approx(math.pi)


def test_every_shipped_servo_has_the_default() -> None:
    profile = load_profile("paper16")
    assert {spec.angle for spec in profile.servos} == {AngleMap()}


def test_a_servo_of_its_own_maps_linearly_and_beyond_its_ends() -> None:
    angle = {"min_us": 1000, "max_us": 2000, "min_deg": -45, "max_deg": 45}
    spec = parse_profile(profile_toml([feature_servo(angle=angle)])).servos[0]
    assert spec.angle.radians(1500) == pytest.approx(0.0)
    assert spec.angle.radians(2000) == pytest.approx(math.pi / 4)
    assert spec.angle.radians(1000) == pytest.approx(-math.pi / 4)
    assert spec.angle.radians(2500) == pytest.approx(math.pi / 2)


def test_a_reversed_map_turns_the_other_way() -> None:
    spec = parse_profile(
        profile_toml([feature_servo(angle={"min_deg": 180, "max_deg": 0})])
    ).servos[0]
    assert spec.angle.radians(500) == pytest.approx(math.pi)
    assert spec.angle.radians(2000) == pytest.approx(math.radians(45))


@pytest.mark.parametrize(
    ("angle", "detail"),
    [
        ({"min_us": 2000, "max_us": 1000}, "angle: needs min_us < max_us (got 2000, 1000)"),
        ({"min_us": 1500, "max_us": 1500}, "angle: needs min_us < max_us (got 1500, 1500)"),
        ({"min_deg": 90, "max_deg": 90}, "angle: min_deg and max_deg are both 90"),
        ({"max_deg": math.inf}, "angle: min_us, max_us, min_deg and max_deg must be finite"),
    ],
    ids=["inverted-pulses", "no-pulse-range", "no-angle-range", "infinite"],
)
def test_a_wrong_map_is_one_line(angle: dict[str, float], detail: str) -> None:
    with pytest.raises(ProfileError, match="servo 'jaw'") as caught:
        parse_profile(profile_toml([feature_servo(angle=angle)]))
    assert detail in str(caught.value)


def test_an_unknown_field_is_refused() -> None:
    with pytest.raises(ProfileError, match="min_rad"):
        parse_profile(profile_toml([feature_servo(angle={"min_rad": 0})]))
