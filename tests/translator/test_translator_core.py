"""services.translator.core: group movements to servo positions (the paper's section 2.2.3)."""

from __future__ import annotations

import math
from importlib import resources
from typing import Any

import numpy as np
import pytest
from translator_fixtures import features_at, jaw_deltas, points_servo, profile_of

from facesynth.runtime import codec
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import Profile, ServoSpec, load_profile
from facesynth.schemas.messages import Features, Points, PointSet, ServoCommands
from facesynth.services.features.core import FeatureProcessor, normalise, nose_distances
from facesynth.services.points.openface_csv import load_openface_csv
from facesynth.services.translator.core import TranslationError, Translator, interpolate


def _spec(**kw: Any) -> ServoSpec:
    fields: dict[str, Any] = dict(
        name="s",
        channel=0,
        points=[30],
        min_us=1000.0,
        neutral_us=1500.0,
        max_us=2000.0,
        face_min=-0.1,
        face_max=0.2,
    )
    fields.update(kw)
    return ServoSpec(**fields)


PLAIN = _spec()
REVERSED = _spec(reversed=True)
ASYM = _spec(min_us=900.0, neutral_us=1200.0, max_us=2100.0)
ASYM_REVERSED = _spec(min_us=900.0, neutral_us=1200.0, max_us=2100.0, reversed=True)
NEUTRAL_AT_MIN = _spec(min_us=1000.0, neutral_us=1000.0, max_us=2000.0)


@pytest.mark.parametrize(
    ("spec", "movement", "expected"),
    [
        (PLAIN, 0.0, 1500.0),
        (PLAIN, 0.2, 2000.0),
        (PLAIN, 0.1, 1750.0),
        (PLAIN, 0.05, 1625.0),
        (PLAIN, 0.4, 2000.0),
        (PLAIN, 1e9, 2000.0),
        (PLAIN, -0.1, 1000.0),
        (PLAIN, -0.05, 1250.0),
        (PLAIN, -0.3, 1000.0),
        (REVERSED, 0.0, 1500.0),
        (REVERSED, 0.2, 1000.0),
        (REVERSED, 0.1, 1250.0),
        (REVERSED, 0.4, 1000.0),
        (REVERSED, -0.1, 2000.0),
        (REVERSED, -0.05, 1750.0),
        (REVERSED, -0.3, 2000.0),
        (ASYM, 0.0, 1200.0),
        (ASYM, 0.2, 2100.0),
        (ASYM, 0.1, 1650.0),
        (ASYM, -0.1, 900.0),
        (ASYM, -0.05, 1050.0),
        (ASYM, 5.0, 2100.0),
        (ASYM, -5.0, 900.0),
        (ASYM_REVERSED, 0.1, 1050.0),
        (ASYM_REVERSED, -0.05, 1650.0),
        (ASYM_REVERSED, 0.2, 900.0),
        (ASYM_REVERSED, -0.1, 2100.0),
        (NEUTRAL_AT_MIN, -0.1, 1000.0),
        (NEUTRAL_AT_MIN, 0.1, 1500.0),
    ],
    ids=[
        "zero-neutral",
        "face-max-max-us",
        "half-up",
        "quarter-up",
        "beyond-max-clamped",
        "far-beyond-max",
        "face-min-min-us",
        "half-down",
        "beyond-min-clamped",
        "rev-zero",
        "rev-face-max-min-us",
        "rev-half-up",
        "rev-beyond-max",
        "rev-face-min-max-us",
        "rev-half-down",
        "rev-beyond-min",
        "asym-zero",
        "asym-face-max",
        "asym-half-up",
        "asym-face-min",
        "asym-half-down",
        "asym-clamp-high",
        "asym-clamp-low",
        "asym-rev-half-up",
        "asym-rev-half-down",
        "asym-rev-face-max",
        "asym-rev-face-min",
        "neutral-at-min-down",
        "neutral-at-min-up",
    ],
)
def test_interpolate(spec: ServoSpec, movement: float, expected: float) -> None:
    assert interpolate(movement, spec.face_min, spec.face_max, spec) == pytest.approx(expected)


def test_interpolate_uses_the_range_it_is_given() -> None:
    # A calibration's range replaces the profile default.
    assert interpolate(0.1, -0.2, 0.4, PLAIN) == pytest.approx(1625.0)
    assert interpolate(-0.1, -0.2, 0.4, PLAIN) == pytest.approx(1250.0)
    assert interpolate(0.1, -0.2, 0.4, REVERSED) == pytest.approx(1375.0)


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        (999.0, 1000.0),
        (1000.0, 1000.0),
        (1234.5, 1234.5),
        (2000.0, 2000.0),
        (2500.0, 2000.0),
        (-math.inf, 1000.0),
        (math.inf, 2000.0),
    ],
    ids=["below", "at-min", "inside", "at-max", "above", "minus-inf", "inf"],
)
def test_clamp(value: float, expected: float) -> None:
    assert PLAIN.clamp(value) == expected


# --- Translator -------------------------------------------------------------------------------


def _profile(servos: list[ServoSpec], *, mirror: bool = False) -> Profile:
    return Profile(name="test", mirror=mirror, servos=servos)


BROWS = [
    _spec(name="right_eyebrow", channel=0, points=[17, 18, 19, 20], face_min=-0.06, face_max=0.08),
    _spec(name="left_eyebrow", channel=1, points=[23, 24, 25, 26], face_min=-0.06, face_max=0.08),
    _spec(name="jaw", channel=2, points=[56, 57, 58], face_min=-0.06, face_max=0.3),
]


def _features(moved: list[float] | np.ndarray | None = None, **kw: Any) -> Features:
    values = [0.0] * 68 if moved is None else list(map(float, moved))
    fields: dict[str, Any] = dict(
        seq=5,
        t_capture_ns=111,
        t_media_ns=222,
        face=True,
        neutral_ready=True,
        distances=[1.0] * len(values),
        deltas=values,
    )
    fields.update(kw)
    return Features(**fields)


def _deltas(points: range | list[int], value: float) -> np.ndarray:
    deltas = np.zeros(68)
    deltas[list(points)] = value
    return deltas


@pytest.mark.parametrize(
    ("mirror", "moved", "right", "left"),
    [
        (False, range(17, 22), 1750.0, 1500.0),
        (False, range(22, 27), 1500.0, 1750.0),
        (True, range(22, 27), 1750.0, 1500.0),
        (True, range(17, 22), 1500.0, 1750.0),
    ],
    ids=["copy-right-brow", "copy-left-brow", "mirror-left-brow", "mirror-right-brow"],
)
def test_mirror(mirror: bool, moved: range, right: float, left: float) -> None:
    translator = Translator(_profile(BROWS, mirror=mirror))
    positions = translator.positions(_deltas(moved, 0.04))
    assert positions == {"right_eyebrow": right, "left_eyebrow": left, "jaw": 1500.0}


def test_group_movement_is_the_mean_of_its_points() -> None:
    translator = Translator(_profile(BROWS))
    deltas = np.zeros(68)
    deltas[[17, 18, 19, 20]] = [0.08, 0.08, 0.0, 0.0]  # mean 0.04: half way up
    deltas[21] = 1.0  # not in the group
    assert translator.positions(deltas)["right_eyebrow"] == pytest.approx(1750.0)


def _calibration(delta_min: np.ndarray, delta_max: np.ndarray) -> Calibration:
    return Calibration(
        name="ann", neutral=[1.0] * 68, delta_min=list(delta_min), delta_max=list(delta_max)
    )


def test_calibration_ranges_are_averaged_over_the_group() -> None:
    low, high = np.zeros(68), np.zeros(68)
    low[[17, 18, 19, 20]] = [-0.1, -0.1, -0.2, -0.2]  # mean -0.15
    high[[17, 18, 19, 20]] = [0.1, 0.2, 0.3, 0.4]  # mean 0.25
    high[23:27] = 0.16  # mean 0.16; lower bound did not move -> profile default (-0.06)
    translator = Translator(_profile(BROWS), _calibration(low, high))
    assert translator._ranges[0] == pytest.approx((-0.15, 0.25))
    assert translator._ranges[1] == pytest.approx((-0.06, 0.16))
    assert translator._ranges[2] == pytest.approx((-0.06, 0.3))  # jaw: not calibrated
    cases = [
        (range(17, 21), 0.125, "right_eyebrow", 1750.0),
        (range(17, 21), 0.25, "right_eyebrow", 2000.0),
        (range(17, 21), -0.075, "right_eyebrow", 1250.0),
        (range(23, 27), 0.08, "left_eyebrow", 1750.0),  # the default range would give 2000
        (range(23, 27), -0.03, "left_eyebrow", 1250.0),
        (range(56, 59), 0.15, "jaw", 1750.0),
    ]
    for points, value, servo, expected in cases:
        got = translator.positions(_deltas(points, value))[servo]
        assert got == pytest.approx(expected), (servo, value)


def test_calibration_ranges_follow_the_mirror() -> None:
    low, high = np.zeros(68), np.zeros(68)
    high[23:27] = 0.2  # the performer's LEFT brow range ...
    high[17:21] = 0.02
    translator = Translator(_profile(BROWS, mirror=True), _calibration(low, high))
    # ... drives the robot's RIGHT eyebrow when mirrored.
    assert translator._ranges[0] == pytest.approx((-0.06, 0.2))
    assert translator.positions(_deltas(range(23, 27), 0.1))["right_eyebrow"] == pytest.approx(
        1750.0
    )


@pytest.mark.parametrize(
    "features",
    [
        _features(_deltas(range(17, 22), 0.5), face=False, distances=[], deltas=[]),
        _features(_deltas(range(17, 22), 0.5), neutral_ready=False, deltas=[]),
        _features(_deltas(range(17, 22), 0.5), neutral_ready=False),
        _features(None, deltas=[]),
    ],
    ids=["no-face", "neutral-not-ready", "not-ready-but-deltas", "no-deltas"],
)
def test_without_tracking_every_servo_is_neutral(features: Features) -> None:
    translator = Translator(load_profile("paper16"))
    commands = translator.translate(features)
    assert commands.positions == load_profile("paper16").neutral_positions()
    assert commands.face is features.face


@pytest.mark.parametrize("count", [0, 1, 67, 69, 136], ids=["0", "1", "67", "69", "136"])
def test_wrong_delta_count(count: int) -> None:
    translator = Translator(_profile(BROWS))
    with pytest.raises(TranslationError, match=f"need 68 deltas, got {count}"):
        translator.positions(np.zeros(count))
    if count:
        with pytest.raises(TranslationError, match=f"need 68 deltas, got {count}"):
            translator.translate(_features(np.zeros(count)))


def test_translate_copies_the_header_and_names_the_profile() -> None:
    translator = Translator(_profile(BROWS))
    commands = translator.translate(_features(_deltas(range(56, 59), 0.15)))
    assert commands == ServoCommands(
        seq=5,
        t_capture_ns=111,
        t_media_ns=222,
        face=True,
        profile="test",
        positions={"right_eyebrow": 1500.0, "left_eyebrow": 1500.0, "jaw": 1750.0},
    )
    assert codec.decode(codec.encode(commands), ServoCommands) == commands


# --- end to end with the shipped profile: F then T on a synthetic real-shaped face ------------


def _mean_shape() -> np.ndarray:
    path = resources.files("facesynth.app.data") / "OpenFace_Test.csv"
    with resources.as_file(path) as file:
        rows = load_openface_csv(file)
    return np.mean([row.points for row in rows], axis=0)


FRAME = normalise(_mean_shape())


def _to_pixels(normalised: np.ndarray) -> np.ndarray:
    theta = math.radians(-12.0)  # a tilted head, 100 px between the outer eye corners
    rotation = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    return 100.0 * normalised @ rotation.T + np.array([320.0, 180.0])


def _paper16_positions(face: np.ndarray) -> dict[str, float]:
    # The neutral goes through the same pixel path, so untouched points give deltas of exactly 0.
    processor = FeatureProcessor(neutral=nose_distances(normalise(_to_pixels(FRAME))))
    coords = _to_pixels(face).ravel().tolist()
    points = Points(
        seq=1,
        t_capture_ns=1,
        t_media_ns=1,
        face=True,
        image_width=640,
        image_height=360,
        sets=[PointSet(scheme="ibug68", dims=2, coords=coords)],
    )
    return Translator(load_profile("paper16")).translate(processor.process(points)).positions


def test_paper16_neutral_face_gives_neutral_servos() -> None:
    positions = _paper16_positions(FRAME)
    assert positions == pytest.approx(load_profile("paper16").neutral_positions(), abs=1e-6)


def test_paper16_raised_right_brow() -> None:
    face = FRAME.copy()
    face[17:22, 1] -= 0.04  # the performer's right brow (17-21) goes up
    positions = _paper16_positions(face)
    assert positions["right_eyebrow"] > 1500 + 100
    assert positions["middle_eyebrow"] > 1500  # 21 is half of the middle group
    assert positions["left_eyebrow"] == 1500.0
    assert positions["jaw"] == 1500.0


def test_paper16_jaw_open() -> None:
    face = FRAME.copy()
    face[56:59, 1] += 0.15  # chin points go down, away from the nose
    expected_movement = float(np.mean(nose_distances(face)[56:59] - nose_distances(FRAME)[56:59]))
    positions = _paper16_positions(face)
    assert positions["jaw"] == pytest.approx(1500 + expected_movement / 0.3 * 500, abs=1e-6)
    assert positions["jaw"] > 1700
    assert positions["right_lower_lip"] > 1500  # 57, 58
    assert positions["left_lower_lip"] > 1500  # 56
    assert positions["right_eyebrow"] == positions["left_eyebrow"] == 1500.0


def test_paper16_cheeks_are_reversed() -> None:
    face = FRAME.copy()
    face[49:51, 1] -= 0.03  # right inner cheek points move up, towards the nose: raised
    positions = _paper16_positions(face)
    assert positions["right_inner_cheek"] > 1500
    assert positions["left_inner_cheek"] == 1500.0


def test_a_position_that_is_not_a_number_stops_its_limiter() -> None:
    translator = Translator(profile_of(points_servo(max_speed=1000.0)))
    limiter = translator._servos[0].limiter
    for index, value in enumerate([0.0, 0.1, 0.2]):
        translator.step(features_at(index, deltas=jaw_deltas(value)))
    assert limiter.velocity > 0.0
    out = translator.step(features_at(3, deltas=jaw_deltas(math.nan)))
    assert math.isnan(out["p"]) and math.isnan(limiter.position or 0.0)
    assert limiter.velocity == 0.0
