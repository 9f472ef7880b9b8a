"""The shipped profiles (paper16: the paper's Table 1, gaze on the eyes; virtual); the reference."""

from __future__ import annotations

import pytest

from facesynth.runtime import blendshapes, profiles
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.profiles import (
    FORMAT_REFERENCE,
    Smoothing,
    load_profile,
    parse_profile,
    validate_profile,
)

# The paper's Table 1 (0-based CLM points), in servo-motor order.
TABLE_1 = [
    ("right_eyebrow", [17, 18, 19, 20]),
    ("left_eyebrow", [23, 24, 25, 26]),
    ("middle_eyebrow", [21, 22]),
    ("right_eye_x", [37, 38, 40, 41]),
    ("right_eye_y", [37, 38, 40, 41]),
    ("left_eye_x", [43, 44, 46, 47]),
    ("left_eye_y", [43, 44, 46, 47]),
    ("right_inner_cheek", [49, 50]),
    ("left_inner_cheek", [51, 52]),
    ("right_outer_cheek", [49, 50, 51]),
    ("left_outer_cheek", [51, 52, 53]),
    ("jaw", [56, 57, 58]),
    ("right_lip_corner", [48]),
    ("left_lip_corner", [54]),
    ("right_lower_lip", [57, 58]),
    ("left_lower_lip", [55, 56]),
]


TABLE_1_GROUPS = {
    "right_eyebrow": [17, 18, 19, 20],
    "left_eyebrow": [23, 24, 25, 26],
    "middle_eyebrow": [21, 22],
    "right_inner_cheek": [49, 50],
    "left_inner_cheek": [51, 52],
    "right_outer_cheek": [49, 50, 51],
    "left_outer_cheek": [51, 52, 53],
    "jaw": [56, 57, 58],
    "right_lip_corner": [48],
    "left_lip_corner": [54],
    "right_lower_lip": [57, 58],
    "left_lower_lip": [55, 56],
}
EYES = {
    "right_eye_x": "gaze_right_x",
    "right_eye_y": "gaze_right_y",
    "left_eye_x": "gaze_left_x",
    "left_eye_y": "gaze_left_y",
}


def test_paper16_is_table_1() -> None:
    profile = load_profile("paper16")
    assert profile.name == "paper16"
    assert profile.scheme == "ibug68"
    assert profile.mirror is False
    assert profile.neutral_seconds == 1.0
    assert [(s.name, s.points) for s in profile.servos] == TABLE_1


def test_paper16_servos_are_the_robots() -> None:
    profile = load_profile("paper16")
    assert sorted(s.channel for s in profile.servos) == list(range(16))
    # "The servos in our robot accept values between 1000 and 2000."
    assert {(s.min_us, s.neutral_us, s.max_us) for s in profile.servos} == {(1000, 1500, 2000)}
    assert {s.name for s in profile.servos if s.reversed} == {
        "right_inner_cheek",
        "left_inner_cheek",
        "right_outer_cheek",
        "left_outer_cheek",
    }
    assert profile.neutral_positions() == {name: 1500 for name, _ in TABLE_1}
    assert profiles.validate_profile(profile) == []


def test_paper16_sources() -> None:
    profile = load_profile("paper16")
    assert validate_profile(profile) == []
    for spec in profile.servos:
        if spec.name in EYES:
            assert spec.feature == EYES[spec.name] and spec.mix is None
            assert spec.points  # the Table 1 group stays as the fallback
        else:
            assert spec.feature is None and spec.mix is None
            assert spec.points == TABLE_1_GROUPS[spec.name]
    assert set(EYES) | set(TABLE_1_GROUPS) == {s.name for s in profile.servos}


def test_paper16_motion_settings() -> None:
    profile = load_profile("paper16")
    assert profile.smoothing == Smoothing(enabled=True, min_cutoff=0.5, beta=1.0, d_cutoff=1.0)
    speeds = {s.name: s.max_speed for s in profile.servos}
    assert all(2000 <= v <= 4000 for n, v in speeds.items() if n not in EYES)
    assert all(speeds[n] > max(v for m, v in speeds.items() if m not in EYES) for n in EYES)
    assert profile.safety.exclusive == []


def test_virtual_profile() -> None:
    profile = load_profile("virtual")
    assert validate_profile(profile) == []
    names = {s.name for s in profile.servos}
    assert names == {
        "brow_right",
        "brow_left",
        "lid_right",
        "lid_left",
        "gaze_right_x",
        "gaze_right_y",
        "gaze_left_x",
        "gaze_left_y",
        "cheek_right",
        "cheek_left",
        "lip_corner_right",
        "lip_corner_left",
        "lower_lip",
        "jaw",
        "head_yaw",
        "head_pitch",
        "head_roll",
    }
    for spec in profile.servos:
        assert not spec.points
        assert set(spec.weights() or {}) <= set(NAMES)
        assert (spec.min_us, spec.max_us) == (0, 1000) and spec.neutral_us in (0, 500)
    assert profile.servo("brow_right").mix == {
        "brow_raise_inner_right": 0.5,
        "brow_raise_outer_right": 0.5,
        "brow_lower_right": -1.0,
    }
    assert profile.servo("lip_corner_left").mix == {
        "lip_corner_pull_left": 1.0,
        "lip_corner_depress_left": -1.0,
    }
    assert "virtual" in profiles.available_profiles()


def test_format_reference_is_a_valid_profile() -> None:
    profile = parse_profile(FORMAT_REFERENCE)
    assert [s.name for s in profile.servos] == ["jaw", "brow_raise", "brow_lower", "smile", "lid"]
    assert not profile.servo("lid").points and profile.servo("lid").weights() is None
    smile = profile.servo("smile")
    assert smile.blendshape == "mouthSmileRight" and smile.one_sided
    assert profile.safety.exclusive[0].servos == ["brow_raise", "brow_lower"]


HEAD16_CHEEKS = ("right_inner_cheek", "left_inner_cheek", "right_outer_cheek", "left_outer_cheek")


@pytest.mark.parametrize(("variant", "base"), [("head16_bs", "head16"), ("virtual_bs", "virtual")])
def test_blendshape_variants_differ_from_their_base_in_the_brows_only(
    variant: str, base: str
) -> None:
    ours, theirs = profiles.load_profile(variant), profiles.load_profile(base)
    assert [s.name for s in ours.servos] == [s.name for s in theirs.servos]
    for mine, other in zip(ours.servos, theirs.servos, strict=True):
        limits = (mine.channel, mine.min_us, mine.neutral_us, mine.max_us, mine.max_speed)
        assert limits == (
            other.channel,
            other.min_us,
            other.neutral_us,
            other.max_us,
            other.max_speed,
        )
        if "brow" in mine.name:
            assert set(mine.weights() or {}) <= set(blendshapes.SHAPES)
            assert "browInnerUp" in (mine.weights() or {})
        else:
            assert mine.weights() == other.weights() and mine.one_sided == other.one_sided


def test_arkit52_is_one_control_per_blendshape() -> None:
    profile = profiles.load_profile("arkit52")
    assert [s.name for s in profile.servos] == list(blendshapes.SHAPES)
    assert [s.channel for s in profile.servos] == list(range(51))
    for spec in profile.servos:
        assert spec.blendshape == spec.name and spec.one_sided
        assert (spec.min_us, spec.neutral_us, spec.max_us) == (0, 0, 1000)
        assert not spec.points and spec.max_speed == 0


@pytest.mark.parametrize(
    ("name", "servos"),
    [
        ("head16", {"jaw", "right_lower_lip", "left_lower_lip", *HEAD16_CHEEKS}),
        ("head16_bs", {"jaw", "right_lower_lip", "left_lower_lip", *HEAD16_CHEEKS}),
        ("paper16", {"jaw", "right_lower_lip", "left_lower_lip"}),
        ("virtual", {"jaw", "lower_lip"}),
        ("virtual_bs", {"jaw", "lower_lip"}),
        ("arkit52", set(blendshapes.SHAPES)),
    ],
)
def test_one_sided_actions_map_one_sided(name: str, servos: set[str]) -> None:
    """The mouth's opening and (head16) the cheeks' raise have no opposite side."""
    profile = profiles.load_profile(name)
    assert {s.name for s in profile.servos if s.one_sided} == servos
