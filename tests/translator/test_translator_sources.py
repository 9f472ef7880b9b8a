"""services.translator.sources (through the core): dead-band, scaling, mixes, gain, mirror, gaps."""

from __future__ import annotations

import numpy as np
import pytest
from translator_fixtures import (
    SMILE,
    feature_servo,
    features_at,
    jaw_deltas,
    points_servo,
    profile_of,
)

from facesynth.runtime.profiles import ServoSpec
from facesynth.services.translator.core import Translator, deadband, mirror_named, scaled_position

# --- mapping pieces -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "width", "expected"),
    [
        (0.0, 0.1, 0.0),
        (0.05, 0.1, 0.0),
        (0.1, 0.1, 0.0),
        (0.1000001, 0.1, 0.0000001),
        (0.5, 0.1, 0.4),
        (-0.05, 0.1, 0.0),
        (-0.5, 0.1, -0.4),
        (0.3, 0.0, 0.3),
        (-0.3, 0.0, -0.3),
    ],
    ids=[
        "zero",
        "inside",
        "edge",
        "just-beyond",
        "beyond",
        "neg-inside",
        "neg-beyond",
        "off",
        "off-neg",
    ],
)
def test_deadband(value: float, width: float, expected: float) -> None:
    assert deadband(value, width) == pytest.approx(expected, abs=1e-12)


def test_deadband_is_continuous_through_the_translator() -> None:
    translator = Translator(profile_of(feature_servo(deadband=0.1)))
    values = np.linspace(-1.2, 1.2, 2401)
    out = [translator.positions(np.zeros(68), {"jaw_open": v})["s"] for v in values]
    steps = np.abs(np.diff(out))
    assert steps.max() <= 500 * (values[1] - values[0]) + 1e-9  # no jump anywhere
    assert translator.positions(np.zeros(68), {"jaw_open": 0.1})["s"] == 1500.0
    assert translator.positions(np.zeros(68), {"jaw_open": 0.6})["s"] == pytest.approx(1750.0)
    assert translator.positions(np.zeros(68), {"jaw_open": -0.6})["s"] == pytest.approx(1250.0)


ASYM = feature_servo(min_us=900.0, neutral_us=1200.0, max_us=2100.0)


@pytest.mark.parametrize(
    ("spec", "value", "expected"),
    [
        (feature_servo(), 0.0, 1500.0),
        (feature_servo(), 1.0, 2000.0),
        (feature_servo(), -1.0, 1000.0),
        (feature_servo(), 0.5, 1750.0),
        (feature_servo(), 1.5, 2000.0),
        (feature_servo(), -1.5, 1000.0),
        (feature_servo(reversed=True), 0.5, 1250.0),
        (feature_servo(reversed=True), -1.0, 2000.0),
        (ASYM, 0.5, 1650.0),
        (ASYM, -0.5, 1050.0),
        (feature_servo(min_us=0.0, neutral_us=0.0, max_us=1000.0), -0.5, 0.0),
    ],
    ids=[
        "zero",
        "one",
        "minus-one",
        "half",
        "beyond-clamped",
        "below-clamped",
        "reversed-half",
        "reversed-minus-one",
        "asym-up",
        "asym-down",
        "one-sided-negative",
    ],
)
def test_scaled_position(spec: ServoSpec, value: float, expected: float) -> None:
    assert scaled_position(value, spec) == pytest.approx(expected)


@pytest.mark.parametrize(
    ("mix", "named", "expected"),
    [
        (SMILE, {"lip_corner_pull_right": 0.0, "lip_corner_depress_right": 0.0}, 1500.0),
        (SMILE, {"lip_corner_pull_right": 0.6, "lip_corner_depress_right": 0.0}, 1800.0),
        (SMILE, {"lip_corner_pull_right": 0.0, "lip_corner_depress_right": 0.6}, 1200.0),
        (SMILE, {"lip_corner_pull_right": 0.6, "lip_corner_depress_right": 0.6}, 1500.0),
        (SMILE, {"lip_corner_pull_right": 0.8, "lip_corner_depress_right": 0.2}, 1800.0),
        (SMILE, {"lip_corner_pull_right": 1.5, "lip_corner_depress_right": 0.0}, 2000.0),
        (
            {"brow_raise_inner_right": 0.5, "brow_raise_outer_right": 0.5, "brow_lower_right": -1},
            {"brow_raise_inner_right": 1.0, "brow_raise_outer_right": 0.2, "brow_lower_right": 0.1},
            1750.0,
        ),
    ],
    ids=["neutral", "smile", "frown", "cancel", "net-smile", "clamped", "brow-three"],
)
def test_mix_is_a_weighted_sum(
    mix: dict[str, float], named: dict[str, float], expected: float
) -> None:
    translator = Translator(profile_of(feature_servo(mix=mix)))
    assert translator.positions(np.zeros(68), named)["s"] == pytest.approx(expected)
    assert translator.step(features_at(0, named))["s"] == pytest.approx(expected)


@pytest.mark.parametrize(
    ("spec", "source", "expected"),
    [
        (feature_servo(gain=2.0), {"jaw_open": 0.25}, 1750.0),
        (feature_servo(gain=0.5), {"jaw_open": -1.0}, 1250.0),
        (feature_servo(gain=-1.0), {"jaw_open": 0.5}, 1250.0),
        (feature_servo(reversed=True, gain=2.0), {"jaw_open": 0.25}, 1250.0),
        (feature_servo(gain=2.0, deadband=0.1), {"jaw_open": 0.35}, 1750.0),  # (0.35 - 0.1) * 2
        (points_servo(name="s", gain=2.0), jaw_deltas(0.05), 1750.0),
        (points_servo(name="s", reversed=True), jaw_deltas(0.1), 1250.0),
        (points_servo(name="s", deadband=0.02), jaw_deltas(0.12), 1750.0),
        (points_servo(name="s", deadband=0.02), jaw_deltas(-0.01), 1500.0),
        (feature_servo(one_sided=True), {"jaw_open": 0.5}, 1750.0),
        (feature_servo(one_sided=True), {"jaw_open": -0.5}, 1500.0),
        (feature_servo(one_sided=True, reversed=True), {"jaw_open": 0.5}, 1250.0),
        (feature_servo(one_sided=True, reversed=True), {"jaw_open": -0.5}, 1500.0),
        (feature_servo(one_sided=True, gain=-1.0), {"jaw_open": -0.5}, 1750.0),
        (points_servo(name="s", one_sided=True), jaw_deltas(0.1), 1750.0),
        (points_servo(name="s", one_sided=True), jaw_deltas(-0.1), 1500.0),
    ],
    ids=[
        "gain-2",
        "gain-half-negative",
        "gain-minus-1",
        "reversed-gain",
        "gain-after-deadband",
        "points-gain",
        "points-reversed",
        "points-deadband-iod",
        "points-inside-deadband",
        "one-sided-open",
        "one-sided-closed-past-neutral",
        "one-sided-reversed-open",
        "one-sided-reversed-closed",
        "one-sided-after-gain",
        "one-sided-points-open",
        "one-sided-points-closed",
    ],
)
def test_gain_reversed_deadband(
    spec: ServoSpec, source: dict[str, float] | np.ndarray, expected: float
) -> None:
    translator = Translator(profile_of(spec))
    frame = features_at(0, source) if isinstance(source, dict) else features_at(0, deltas=source)
    assert translator.step(frame)["s"] == pytest.approx(expected)


@pytest.mark.parametrize(
    ("named", "mirrored"),
    [
        ({"jaw_open": 0.3}, {"jaw_open": 0.3}),
        ({"gaze_right_x": 0.5}, {"gaze_left_x": -0.5}),
        ({"gaze_left_y": 0.5}, {"gaze_right_y": 0.5}),
        ({"brow_raise_inner_right": 0.2}, {"brow_raise_inner_left": 0.2}),
        ({"head_yaw": 0.4, "head_pitch": 0.1}, {"head_yaw": -0.4, "head_pitch": 0.1}),
        (
            {"lip_corner_pull_left": 0.7, "lip_corner_pull_right": 0.1},
            {"lip_corner_pull_right": 0.7, "lip_corner_pull_left": 0.1},
        ),
        ({"mouthSmileLeft": 0.4}, {"mouthSmileRight": 0.4}),
        ({"eyeLookInRight": 0.5, "jawOpen": 0.2}, {"eyeLookInLeft": 0.5, "jawOpen": 0.2}),
        ({"jawLeft": 0.3, "mouthRight": 0.1}, {"jawRight": 0.3, "mouthLeft": 0.1}),
    ],
    ids=[
        "central",
        "gaze-x",
        "gaze-y",
        "brow",
        "head",
        "swap-both",
        "blendshape",
        "blendshape-eye-and-central",
        "blendshape-directions",
    ],
)
def test_mirror_named(named: dict[str, float], mirrored: dict[str, float]) -> None:
    assert mirror_named(named) == mirrored
    assert mirror_named(mirror_named(named)) == named


def test_a_blendshape_drives_its_servo() -> None:
    profile = profile_of(feature_servo(blendshape="mouthSmileLeft", min_us=0.0, neutral_us=0.0))
    translator = Translator(profile)
    assert translator.step(features_at(0, {"mouthSmileLeft": 0.5}))["s"] == pytest.approx(1000.0)
    mirrored = Translator(profile_of(profile.servos[0], mirror=True))
    assert mirrored.step(features_at(0, {"mouthSmileRight": 0.25}))["s"] == pytest.approx(500.0)


def test_mirror_drives_the_right_eye_from_the_left() -> None:
    profile = profile_of(feature_servo("eye", feature="gaze_right_x"), mirror=True)
    out = Translator(profile).step(features_at(0, {"gaze_left_x": 0.5, "gaze_right_x": -0.2}))
    assert out["eye"] == pytest.approx(1250.0)  # the performer looks left: the image looks right


# --- missing sources ------------------------------------------------------------------------------


def test_missing_feature_holds_then_resumes() -> None:
    profile = profile_of(feature_servo("gaze", feature="gaze_right_y"), feature_servo("jaw", 1))
    translator = Translator(profile)
    frames = [
        features_at(0, {"jaw_open": 0.2}),  # no gaze yet: neutral
        features_at(1, {"jaw_open": 0.2, "gaze_right_y": 0.5}),
        features_at(2, {"jaw_open": 0.4}),  # gaze missing: hold
        features_at(3, {"jaw_open": 0.4}),
        features_at(4, {"jaw_open": 0.4, "gaze_right_y": -0.5}),
    ]
    out = [translator.step(frame) for frame in frames]
    assert [o["gaze"] for o in out] == pytest.approx([1500.0, 1750.0, 1750.0, 1750.0, 1250.0])
    assert [o["jaw"] for o in out] == pytest.approx([1600.0, 1600.0, 1700.0, 1700.0, 1700.0])


def test_missing_mix_component_holds() -> None:
    translator = Translator(profile_of(feature_servo(mix=SMILE)))
    assert translator.step(
        features_at(0, {"lip_corner_pull_right": 0.5, "lip_corner_depress_right": 0})
    )["s"] == pytest.approx(1750.0)
    assert translator.step(features_at(1, {"lip_corner_pull_right": 0.0}))["s"] == pytest.approx(
        1750.0
    )


def test_points_servo_without_deltas_holds() -> None:
    translator = Translator(profile_of(points_servo(name="s"), feature_servo("jaw", 1)))
    assert translator.step(features_at(0, deltas=jaw_deltas(0.1)))["s"] == pytest.approx(1750.0)
    out = translator.step(features_at(1, {"jaw_open": 0.5}))  # named only: the group holds
    assert out == pytest.approx({"s": 1750.0, "jaw": 1750.0})


def test_points_fallback_until_the_feature_is_seen() -> None:
    eye = feature_servo(
        "eye", feature="gaze_right_y", points=[56, 57, 58], face_min=-0.1, face_max=0.2
    )
    translator = Translator(profile_of(eye))
    # A stream without an iris (OpenFace replay): the Table 1 group drives the eye.
    assert translator.step(features_at(0, deltas=jaw_deltas(0.1)))["eye"] == pytest.approx(1750.0)
    assert translator.step(features_at(1, deltas=jaw_deltas(-0.05)))["eye"] == pytest.approx(1250.0)
    # Gaze arrives: it drives the eye from now on ...
    assert translator.step(features_at(2, {"gaze_right_y": 0.8}, jaw_deltas(0.1)))[
        "eye"
    ] == pytest.approx(1900.0)
    # ... and a frame without it holds, it does not fall back to the lid points.
    assert translator.step(features_at(3, deltas=jaw_deltas(-0.1)))["eye"] == pytest.approx(1900.0)
    translator.reset()
    assert translator.step(features_at(4, deltas=jaw_deltas(0.2)))["eye"] == pytest.approx(2000.0)


def test_fallback_deadband_is_in_scaled_units() -> None:
    eye = feature_servo(
        "eye",
        feature="gaze_right_y",
        points=[56, 57, 58],
        face_min=-0.1,
        face_max=0.1,
        deadband=0.1,
    )
    translator = Translator(profile_of(eye))
    # Half range 0.1 IOD: the dead-band 0.1 (scaled) is 0.01 IOD on the points.
    assert translator.step(features_at(0, deltas=jaw_deltas(0.06)))["eye"] == pytest.approx(1750.0)
