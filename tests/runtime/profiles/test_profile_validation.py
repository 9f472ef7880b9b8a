"""runtime.profiles.validation: valid variations; one precise message per way a profile is wrong."""

from __future__ import annotations

import math
from typing import Any

import pytest
from profile_toml import PAIR, POINTS, feature_servo, points_servo, points_toml, profile_toml

from facesynth.runtime.profiles import ProfileError, parse_profile, validate_profile

# --- valid variations -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "servo",
    [
        points_servo(min_us=900, neutral_us=900, max_us=2100),
        points_servo(min_us=900, neutral_us=2100, max_us=2100),
        points_servo(points=[0, 67]),
        points_servo(channel=0, min_us=0),
    ],
    ids=["neutral-at-min", "neutral-at-max", "first-and-last-point", "zero-min"],
)
def test_edge_values_are_valid(servo: dict[str, Any]) -> None:
    assert parse_profile(points_toml([servo])).servos[0].points == servo["points"]


@pytest.mark.parametrize(
    ("servos", "top"),
    [
        ([feature_servo()], {}),
        ([feature_servo(feature=None, mix={"lip_corner_pull_right": 1.0, "jaw_open": -0.5})], {}),
        ([feature_servo(**POINTS)], {}),
        ([feature_servo(points=[37, 38], face_min=-0.04, face_max=0.04)], {}),  # feature + fallback
        ([feature_servo(gain=-2.0, deadband=0.0, max_speed=0, max_accel=0)], {}),
        ([feature_servo(smoothing={"enabled": False})], {}),
        ([feature_servo(min_us=0, neutral_us=0, max_us=1000)], {"neutral_ramp_s": 0}),
        ([feature_servo(smoothing={"beta": 0.0})], {}),
        ([feature_servo(feature=None, blendshape="mouthSmileLeft")], {}),
        ([feature_servo(feature=None, mix={"mouthSmileLeft": 1.0, "mouthFrownLeft": -1.0})], {}),
        ([feature_servo(feature=None, mix={"jawOpen": 0.5, "jaw_open": 0.5})], {}),
        ([feature_servo(one_sided=True)], {}),
        ([feature_servo(**{**POINTS, "blendshape": "jawOpen", "one_sided": True})], {}),
    ],
    ids=[
        "feature",
        "mix",
        "points",
        "feature-with-fallback",
        "negative-gain",
        "servo-smoothing-off",
        "zero-based-no-ramp",
        "beta-zero",
        "blendshape",
        "mix-of-blendshapes",
        "mix-of-blendshape-and-feature",
        "one-sided",
        "one-sided-blendshape-with-fallback",
    ],
)
def test_valid_profiles(servos: list[dict[str, Any]], top: dict[str, Any]) -> None:
    profile = parse_profile(profile_toml(servos, **top))
    assert validate_profile(profile) == []


def test_valid_safety_rule_and_threshold_one() -> None:
    text = profile_toml(PAIR, exclusive=[{"servos": ["up", "down"], "threshold": 1.0}])
    assert parse_profile(text).safety.exclusive[0].threshold == 1.0
    assert parse_profile(
        profile_toml(PAIR, exclusive=[{"servos": ["up", "down"]}])
    ).safety.exclusive[0].threshold == pytest.approx(0.8)


# --- the structure, the servos' channels, limits and point groups ---------------------------------


@pytest.mark.parametrize(
    ("text", "detail"),
    [
        ('name = "x"\n[[servos]\n', "not valid TOML"),
        ("name = \n", "not valid TOML"),
        (points_toml(colour="red"), "Object contains unknown field `colour`"),
        (
            points_toml([points_servo(speed=3)]),
            "Object contains unknown field `speed` - at `$.servos[0]`",
        ),
        ('name = "x"\n', "Object missing required field `servos`"),
        (
            points_toml([{k: v for k, v in points_servo().items() if k != "max_us"}]),
            "Object missing required field `max_us` - at `$.servos[0]`",
        ),
        (
            points_toml([points_servo(channel="zero")]),
            "Expected `int`, got `str` - at `$.servos[0].channel`",
        ),
        (
            points_toml([points_servo(points=18)]),
            "Expected `array`, got `int` - at `$.servos[0].points`",
        ),
        (points_toml(mirror="yes"), "Expected `bool`, got `str` - at `$.mirror`"),
        (points_toml(name=""), "name is empty"),
        (points_toml(scheme="mesh468"), "scheme 'mesh468' is not supported (use 'ibug68')"),
        (points_toml(neutral_seconds=0), "neutral_seconds must be a positive number"),
        (points_toml(neutral_seconds=-1.0), "neutral_seconds must be a positive number"),
        (points_toml(neutral_seconds=float("nan")), "neutral_seconds must be a positive number"),
        ('name = "x"\nservos = []\n', "no servos"),
        (points_toml([points_servo(name="")]), "a servo has an empty name"),
        (points_toml([points_servo(), points_servo(channel=1)]), "servo 'jaw' is defined twice"),
        (
            points_toml([points_servo(), points_servo(name="lip")]),
            "servo 'lip': channel 0 is used twice",
        ),
        (points_toml([points_servo(channel=-1)]), "servo 'jaw': channel -1 is negative"),
        (
            points_toml([points_servo(min_us=2100)]),
            "servo 'jaw': needs min_us <= neutral_us <= max_us and min_us < max_us "
            "(got 2100, 1500, 2000)",
        ),
        (points_toml([points_servo(neutral_us=2500)]), "(got 1000, 2500, 2000)"),
        (points_toml([points_servo(neutral_us=900)]), "(got 1000, 900, 2000)"),
        (
            points_toml([points_servo(min_us=1500, neutral_us=1500, max_us=1500)]),
            "min_us < max_us (got 1500, 1500, 1500)",
        ),
        (
            points_toml([points_servo(min_us=-10, neutral_us=0)]),
            "servo 'jaw': min_us -10 is negative",
        ),
        (
            points_toml([points_servo(face_min=0)]),
            "servo 'jaw': needs face_min < 0 < face_max (got 0, 0.2)",
        ),
        (
            points_toml([points_servo(face_min=0.05)]),
            "needs face_min < 0 < face_max (got 0.05, 0.2)",
        ),
        (points_toml([points_servo(face_max=0)]), "needs face_min < 0 < face_max (got -0.1, 0)"),
        (
            points_toml([points_servo(face_max=-0.2)]),
            "needs face_min < 0 < face_max (got -0.1, -0.2)",
        ),
        (
            points_toml([points_servo(max_us=float("nan"))]),
            "servo 'jaw': limits and ranges must be finite numbers",
        ),
        (
            points_toml([points_servo(face_max=float("inf"))]),
            "limits and ranges must be finite numbers",
        ),
        (
            points_toml([points_servo(points=[])]),
            "servo 'jaw': face_min/face_max apply to points only (no points given)",
        ),
        (
            points_toml([points_servo(points=[56, 68])]),
            "servo 'jaw': points [68] are outside 0..67",
        ),
        (points_toml([points_servo(points=[-1, 30, 99])]), "points [-1, 99] are outside 0..67"),
    ],
    ids=[
        "bad-toml-table",
        "bad-toml-value",
        "unknown-top-field",
        "unknown-servo-field",
        "no-servos-key",
        "missing-max",
        "channel-str",
        "points-int",
        "mirror-str",
        "empty-name",
        "unsupported-scheme",
        "neutral-seconds-zero",
        "neutral-seconds-negative",
        "neutral-seconds-nan",
        "empty-servos",
        "empty-servo-name",
        "duplicate-name",
        "duplicate-channel",
        "negative-channel",
        "min-above-max",
        "neutral-above-max",
        "neutral-below-min",
        "min-equals-max",
        "negative-min",
        "face-min-zero",
        "face-min-positive",
        "face-max-zero",
        "face-max-negative",
        "nan-limit",
        "inf-range",
        "face-range-without-points",
        "point-68",
        "points-negative-and-99",
    ],
)
def test_invalid_structure_channels_limits_and_points(text: str, detail: str) -> None:
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "robot.toml")
    message = str(info.value)
    assert message.startswith("robot.toml: ")
    assert detail in message


# --- sources, motion, smoothing and safety rules --------------------------------------------------


@pytest.mark.parametrize(
    ("text", "detail"),
    [
        (
            profile_toml([feature_servo(mix={"jaw_open": 1.0})]),
            "servo 'jaw': several sources (feature and mix); give exactly one "
            "(points may accompany any of them as a fallback)",
        ),
        (
            profile_toml([feature_servo(blendshape="jawOpen")]),
            "servo 'jaw': several sources (feature and blendshape); give exactly one",
        ),
        (
            profile_toml([feature_servo(feature=None, blendshape="mouthSmileLft")]),
            "servo 'jaw': unknown blendshape 'mouthSmileLft' (did you mean 'mouthSmileLeft'?)",
        ),
        (
            profile_toml([feature_servo(feature=None, blendshape="_neutral")]),
            "servo 'jaw': unknown blendshape '_neutral' (one of the 51 ARKit names",
        ),
        (
            profile_toml([feature_servo(feature=None, blendshape="jaw_open")]),
            "servo 'jaw': 'jaw_open' is a feature, not a blendshape (use feature = 'jaw_open')",
        ),
        (
            profile_toml([feature_servo(feature=None, blendshape="")]),
            "servo 'jaw': unknown blendshape ''",
        ),
        (
            profile_toml([feature_servo(feature=None, mix={"mouthSmileLeft": 1.0, "smileX": 1.0})]),
            "servo 'jaw': mix: unknown feature 'smileX'",
        ),
        (
            profile_toml([feature_servo(feature=None, blendshape=3)]),
            "servo 'jaw': Expected `str | null`, got `int` - at `$.servos[0].blendshape`",
        ),
        (
            profile_toml([feature_servo(one_sided="yes")]),
            "servo 'jaw': Expected `bool`, got `str` - at `$.servos[0].one_sided`",
        ),
        (
            profile_toml([feature_servo(feature="jaw_opn")]),
            "servo 'jaw': unknown feature 'jaw_opn' (did you mean 'jaw_open'?)",
        ),
        (
            profile_toml([feature_servo(feature="tail_wag")]),
            "servo 'jaw': unknown feature 'tail_wag' (see facesynth.runtime.feature_names)",
        ),
        (
            profile_toml([feature_servo(feature=None, mix={})]),
            "servo 'jaw': mix is empty (give named features and their weights)",
        ),
        (
            profile_toml([feature_servo(feature=None, mix={"smile_right": 1.0})]),
            "servo 'jaw': mix: unknown feature 'smile_right'",
        ),
        (
            profile_toml([feature_servo(feature=None, mix={"jaw_open": math.nan})]),
            "servo 'jaw': mix weight of 'jaw_open' must be a finite non-zero number (got nan)",
        ),
        (
            profile_toml([feature_servo(feature=None, mix={"jaw_open": math.inf})]),
            "servo 'jaw': mix weight of 'jaw_open' must be a finite non-zero number (got inf)",
        ),
        (
            profile_toml([feature_servo(feature=None, mix={"jaw_open": 1.0, "lips_part": 0.0})]),
            "servo 'jaw': mix weight of 'lips_part' must be a finite non-zero number (got 0)",
        ),
        (
            profile_toml([feature_servo(face_max=0.2)]),
            "servo 'jaw': face_min/face_max apply to points only (no points given)",
        ),
        (
            profile_toml([feature_servo(**{**POINTS, "face_max": None})]),
            "servo 'jaw': points need face_min and face_max (missing ['face_max'])",
        ),
        (
            profile_toml([feature_servo(feature=None, points=[56])]),
            "servo 'jaw': points need face_min and face_max (missing ['face_min', 'face_max'])",
        ),
        (
            profile_toml([feature_servo(gain=0.0)]),
            "servo 'jaw': gain must be a finite non-zero number (got 0)",
        ),
        (
            profile_toml([feature_servo(gain=math.nan)]),
            "servo 'jaw': gain must be a finite non-zero number (got nan)",
        ),
        (
            profile_toml([feature_servo(deadband=-0.01)]),
            "servo 'jaw': deadband must be a finite number >= 0 (source units; got -0.01)",
        ),
        (
            profile_toml([feature_servo(max_speed=-100)]),
            "servo 'jaw': max_speed must be a finite number >= 0 (µs/s; 0 = unlimited; got -100)",
        ),
        (
            profile_toml([feature_servo(max_speed=math.inf)]),
            "servo 'jaw': max_speed must be a finite number >= 0 (µs/s; 0 = unlimited; got inf)",
        ),
        (
            profile_toml([feature_servo(max_accel=-1)]),
            "servo 'jaw': max_accel must be a finite number >= 0 (µs/s²; 0 = unlimited; got -1)",
        ),
        (
            profile_toml(smoothing={"min_cutoff": 0.0}),
            "smoothing.min_cutoff must be a positive number of Hz (got 0)",
        ),
        (
            profile_toml(smoothing={"d_cutoff": -1.0}),
            "smoothing.d_cutoff must be a positive number of Hz (got -1)",
        ),
        (profile_toml(smoothing={"beta": -0.5}), "smoothing.beta must be a number >= 0 (got -0.5)"),
        (
            profile_toml(smoothing={"min_cutoff": math.nan}),
            "smoothing.min_cutoff must be a positive number of Hz (got nan)",
        ),
        (
            profile_toml([feature_servo(smoothing={"min_cutoff": 0.0})]),
            "servo 'jaw': smoothing.min_cutoff must be a positive number of Hz (got 0)",
        ),
        (
            profile_toml(neutral_ramp_s=-0.5),
            "neutral_ramp_s must be a number of seconds >= 0 (got -0.5)",
        ),
        (
            profile_toml(max_command_age_s=0.0),
            "max_command_age_s must be a number of seconds from 0.02 to 5 (got 0)",
        ),
        (
            profile_toml(max_command_age_s=60),
            "max_command_age_s must be a number of seconds from 0.02 to 5 (got 60)",
        ),
        (
            profile_toml(max_command_age_s=math.inf),
            "max_command_age_s must be a number of seconds from 0.02 to 5 (got inf)",
        ),
        (
            profile_toml(PAIR, exclusive=[{"servos": ["up", "sideways"]}]),
            "safety.exclusive[0]: unknown servos ['sideways']",
        ),
        (
            profile_toml(PAIR, exclusive=[{"servos": ["up"]}]),
            "safety.exclusive[0]: needs two or more different servos (got ['up'])",
        ),
        (
            profile_toml(PAIR, exclusive=[{"servos": ["up", "up"]}]),
            "safety.exclusive[0]: needs two or more different servos (got ['up', 'up'])",
        ),
        (
            profile_toml(PAIR, exclusive=[{"servos": ["up", "down"], "threshold": 0.0}]),
            "safety.exclusive[0]: threshold 0 is outside (0, 1]",
        ),
        (
            profile_toml(PAIR, exclusive=[{"servos": ["up", "down"], "threshold": 1.5}]),
            "safety.exclusive[0]: threshold 1.5 is outside (0, 1]",
        ),
        (
            profile_toml(
                PAIR,
                exclusive=[{"servos": ["up", "down"]}, {"servos": ["down", "up"], "threshold": -1}],
            ),
            "safety.exclusive[1]: threshold -1 is outside (0, 1]",
        ),
        (
            profile_toml(smoothing={"alpha": 1.0}),
            "Object contains unknown field `alpha` - at `$.smoothing`",
        ),
        (
            profile_toml([feature_servo(feature=None, mix={"jaw_open": "lots"})]),
            "servo 'jaw': Expected `float`, got `str` - at `$.servos[0].mix[...]`",
        ),
        (
            profile_toml([feature_servo(smoothing={"speed": 2.0})]),
            "servo 'jaw': Object contains unknown field `speed` - at `$.servos[0].smoothing`",
        ),
        (
            profile_toml(PAIR, exclusive=[{"servos": "up"}]),
            "Expected `array`, got `str` - at `$.safety.exclusive[0].servos`",
        ),
    ],
    ids=[
        "feature-and-mix",
        "feature-and-blendshape",
        "blendshape-misspelt",
        "blendshape-neutral",
        "blendshape-is-a-feature",
        "blendshape-empty",
        "mix-of-blendshapes-unknown",
        "blendshape-not-a-string",
        "one-sided-not-a-bool",
        "unknown-feature-close",
        "unknown-feature-far",
        "empty-mix",
        "mix-unknown-feature",
        "mix-weight-nan",
        "mix-weight-inf",
        "mix-weight-zero",
        "face-range-without-points",
        "points-without-face-max",
        "points-without-face-range",
        "gain-zero",
        "gain-nan",
        "deadband-negative",
        "max-speed-negative",
        "max-speed-inf",
        "max-accel-negative",
        "min-cutoff-zero",
        "d-cutoff-negative",
        "beta-negative",
        "min-cutoff-nan",
        "servo-min-cutoff-zero",
        "neutral-ramp-negative",
        "command-age-zero",
        "command-age-a-minute",
        "command-age-infinite",
        "safety-unknown-servo",
        "safety-one-servo",
        "safety-same-servo-twice",
        "safety-threshold-zero",
        "safety-threshold-above-one",
        "safety-second-rule",
        "smoothing-unknown-field",
        "mix-weight-string",
        "servo-smoothing-unknown-field",
        "safety-servos-not-a-list",
    ],
)
def test_invalid_sources_motion_smoothing_and_safety(text: str, detail: str) -> None:
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "robot.toml")
    message = str(info.value)
    assert message.startswith("robot.toml: ")
    assert detail in message
    assert any(detail in problem for problem in info.value.problems)
    assert all(problem.startswith("robot.toml: ") for problem in info.value.problems)


# --- smart servo buses (issue 26) -----------------------------------------------------------------


def test_bus_fields_are_valid() -> None:
    text = profile_toml(
        [
            feature_servo(bus_id=7, model="XL430-W250", native_min=1024, native_max=3072),
            feature_servo(name="brow", channel=6),  # default id: channel + 1 = 7, taken
        ],
        bus={"baud": 1000000, "protocol": 2},
    )
    with pytest.raises(ProfileError, match="servo 'brow': bus id 7 is taken by servo 'jaw'"):
        parse_profile(text)
    ok = profile_toml(
        [
            feature_servo(bus_id=7, native_min=3072, native_max=1024),
            feature_servo(name="b", channel=1),
        ],
        bus={"baud": 57600},
    )
    profile = parse_profile(ok)
    assert profile.bus is not None and profile.bus.baud == 57600
    assert (profile.servos[0].bus_id, profile.servos[1].bus_id) == (7, None)


@pytest.mark.parametrize(
    ("text", "detail"),
    [
        (profile_toml([feature_servo(bus_id=253)]), "servo 'jaw': bus_id 253 is outside 0..252"),
        (
            profile_toml([feature_servo(native_min=10)]),
            "servo 'jaw': give native_min and native_max together",
        ),
        (
            profile_toml([feature_servo(native_min=10, native_max=10)]),
            "servo 'jaw': native_min and native_max must differ and be >= 0 (got 10, 10)",
        ),
        (
            profile_toml([feature_servo(native_min=-1, native_max=10)]),
            "native_min and native_max must differ and be >= 0 (got -1, 10)",
        ),
        (profile_toml(bus={"baud": 0}), "bus.baud must be a positive baud rate (got 0)"),
        (profile_toml(bus={"protocol": 3}), "bus.protocol must be 1 or 2 (got 3)"),
        (profile_toml(bus={"parity": "odd"}), "Object contains unknown field `parity`"),
    ],
    ids=[
        "bus-id-253",
        "native-min-alone",
        "native-equal",
        "native-negative",
        "baud-zero",
        "protocol-3",
        "bus-unknown-field",
    ],
)
def test_invalid_bus_fields(text: str, detail: str) -> None:
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "robot.toml")
    assert detail in str(info.value)
