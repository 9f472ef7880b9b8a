"""The translator with the shipped profiles: paper16's eyes follow the iris; virtual's controls."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest
from translator_fixtures import DT, features_at

from facesynth.runtime.profiles import load_profile
from facesynth.services.translator.core import Translator


@pytest.mark.parametrize(
    ("named", "servo", "expected"),
    [
        ({"gaze_right_y": 1.05}, "right_eye_y", 2000.0),  # up (0.05 dead-band)
        ({"gaze_right_y": -0.55}, "right_eye_y", 1250.0),  # down
        ({"gaze_left_x": 0.55}, "left_eye_x", 1750.0),  # toward the performer's left
        ({"gaze_right_x": -1.05}, "right_eye_x", 1000.0),
    ],
    ids=["right-up", "right-down", "left-x", "right-x-min"],
)
def test_paper16_eyes_follow_the_iris(named: dict[str, float], servo: str, expected: float) -> None:
    out = Translator(load_profile("paper16")).step(features_at(0, named, np.zeros(68)))
    assert out[servo] == pytest.approx(expected)
    assert {n: v for n, v in out.items() if n != servo} == {n: 1500.0 for n in out if n != servo}


@pytest.mark.parametrize(
    ("named", "expected"),
    [
        ({"jaw_open": 1.0}, {"jaw": 1000.0}),
        ({"jaw_open": -0.5}, {"jaw": 0.0}),
        ({"lips_part": 0.5}, {"lower_lip": 500.0}),
        ({"lip_corner_pull_left": 1.0, "lip_corner_depress_left": 0.0}, {"lip_corner_left": 1000}),
        ({"lip_corner_pull_right": 0.0, "lip_corner_depress_right": 1.0}, {"lip_corner_right": 0}),
        (
            {"brow_raise_inner_right": 1.0, "brow_raise_outer_right": 1.0, "brow_lower_right": 0},
            {"brow_right": 1000.0},
        ),
        (
            {"brow_raise_inner_left": 0.0, "brow_raise_outer_left": 0.0, "brow_lower_left": 0.5},
            {"brow_left": 250.0},
        ),
        ({"eye_open_right": -1.0}, {"lid_right": 0.0}),
        ({"cheek_raise_left": 0.3}, {"cheek_left": 300.0}),
        ({"gaze_left_y": 0.55}, {"gaze_left_y": 750.0}),
    ],
    ids=[
        "jaw-open",
        "jaw-clenched",
        "lips-part",
        "smile-left",
        "frown-right",
        "brow-up",
        "brow-frown",
        "lid-closed",
        "cheek",
        "gaze-up",
    ],
)
def test_virtual_controls(named: dict[str, float], expected: dict[str, float]) -> None:
    profile = load_profile("virtual")
    out = Translator(profile).step(features_at(0, named))
    assert out == pytest.approx({**profile.neutral_positions(), **expected})


def test_virtual_with_limits_swapped_in_still_works() -> None:
    profile = load_profile("virtual")
    servos = [msgspec.structs.replace(s, max_speed=1000.0) for s in profile.servos]
    translator = Translator(msgspec.structs.replace(profile, servos=servos))
    translator.step(features_at(0, {"jaw_open": 0.0}))
    assert translator.step(features_at(1, {"jaw_open": 1.0}))["jaw"] == pytest.approx(1000.0 * DT)
