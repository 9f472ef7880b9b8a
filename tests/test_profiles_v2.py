"""runtime.profiles, the extended format: sources, motion, smoothing, safety, shipped profiles."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from facesynth.app.cli import main
from facesynth.runtime import profiles
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.profiles import (
    FORMAT_REFERENCE,
    ProfileError,
    Smoothing,
    describe_source,
    load_profile,
    parse_profile,
    validate_profile,
)

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


@pytest.fixture(autouse=True)
def _isolated(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """No user profiles: HOME is empty and $FACESYNTH_PROFILES is unset."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("FACESYNTH_PROFILES", raising=False)


# --- a small TOML writer for test profiles ----------------------------------------------------


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, float) and math.isnan(value):
        return "nan"
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return repr(value)


def _servo(**kw: Any) -> dict[str, Any]:
    servo: dict[str, Any] = dict(
        name="jaw", channel=0, min_us=1000, neutral_us=1500, max_us=2000, feature="jaw_open"
    )
    servo.update(kw)
    return {k: v for k, v in servo.items() if v is not None}


def _toml(
    servos: list[dict[str, Any]] | None = None,
    *,
    smoothing: dict[str, Any] | None = None,
    exclusive: list[dict[str, Any]] | None = None,
    **top: Any,
) -> str:
    head: dict[str, Any] = {"name": "test"}
    head.update(top)
    lines = [f"{key} = {_value(value)}" for key, value in head.items()]
    if smoothing is not None:
        lines.append("[smoothing]")
        lines.extend(f"{key} = {_value(value)}" for key, value in smoothing.items())
    for servo in [_servo()] if servos is None else servos:
        lines.append("[[servos]]")
        lines.extend(f"{key} = {_value(value)}" for key, value in servo.items())
    for rule in exclusive or []:
        lines.append("[[safety.exclusive]]")
        lines.extend(f"{key} = {_value(value)}" for key, value in rule.items())
    return "\n".join(lines) + "\n"


PAIR = [_servo(name="up", channel=0), _servo(name="down", channel=1, feature="brow_lower_right")]
POINTS = dict(feature=None, points=[56, 57, 58], face_min=-0.1, face_max=0.2)


# --- shipped profiles -------------------------------------------------------------------------


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
    assert [s.name for s in profile.servos] == ["jaw", "brow_raise", "brow_lower"]
    assert profile.safety.exclusive[0].servos == ["brow_raise", "brow_lower"]


# --- valid variations -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("servos", "top"),
    [
        ([_servo()], {}),
        ([_servo(feature=None, mix={"lip_corner_pull_right": 1.0, "jaw_open": -0.5})], {}),
        ([_servo(**POINTS)], {}),
        ([_servo(points=[37, 38], face_min=-0.04, face_max=0.04)], {}),  # feature + fallback
        ([_servo(gain=-2.0, deadband=0.0, max_speed=0, max_accel=0)], {}),
        ([_servo(smoothing={"enabled": False})], {}),
        ([_servo(min_us=0, neutral_us=0, max_us=1000)], {"neutral_ramp_s": 0}),
        ([_servo(smoothing={"beta": 0.0})], {}),
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
    ],
)
def test_valid_profiles(servos: list[dict[str, Any]], top: dict[str, Any]) -> None:
    profile = parse_profile(_toml(servos, **top))
    assert validate_profile(profile) == []


def test_defaults_of_the_new_fields() -> None:
    profile = parse_profile(_toml())
    (spec,) = profile.servos
    assert (spec.gain, spec.deadband, spec.max_speed, spec.max_accel) == (1.0, 0.0, 0.0, 0.0)
    assert spec.smoothing is None and spec.points == [] and spec.face_min is None
    assert profile.smoothing is None and profile.neutral_ramp_s == 0.5
    assert profile.safety.exclusive == []
    assert profile.smoothing_for(spec) is None


def test_valid_safety_rule_and_threshold_one() -> None:
    text = _toml(PAIR, exclusive=[{"servos": ["up", "down"], "threshold": 1.0}])
    assert parse_profile(text).safety.exclusive[0].threshold == 1.0
    assert parse_profile(_toml(PAIR, exclusive=[{"servos": ["up", "down"]}])).safety.exclusive[
        0
    ].threshold == pytest.approx(0.8)


# --- invalid profiles: one case per message ---------------------------------------------------


@pytest.mark.parametrize(
    ("text", "detail"),
    [
        (
            _toml([_servo(feature=None)]),
            "servo 'jaw': no points, feature or mix (give exactly one source)",
        ),
        (
            _toml([_servo(mix={"jaw_open": 1.0})]),
            "servo 'jaw': several sources (feature and mix); give exactly one "
            "(points may accompany either as a fallback)",
        ),
        (
            _toml([_servo(feature="jaw_opn")]),
            "servo 'jaw': unknown feature 'jaw_opn' (did you mean 'jaw_open'?)",
        ),
        (
            _toml([_servo(feature="tail_wag")]),
            "servo 'jaw': unknown feature 'tail_wag' (see facesynth.runtime.feature_names)",
        ),
        (
            _toml([_servo(feature=None, mix={})]),
            "servo 'jaw': mix is empty (give named features and their weights)",
        ),
        (
            _toml([_servo(feature=None, mix={"smile_right": 1.0})]),
            "servo 'jaw': mix: unknown feature 'smile_right'",
        ),
        (
            _toml([_servo(feature=None, mix={"jaw_open": math.nan})]),
            "servo 'jaw': mix weight of 'jaw_open' must be a finite non-zero number (got nan)",
        ),
        (
            _toml([_servo(feature=None, mix={"jaw_open": math.inf})]),
            "servo 'jaw': mix weight of 'jaw_open' must be a finite non-zero number (got inf)",
        ),
        (
            _toml([_servo(feature=None, mix={"jaw_open": 1.0, "lips_part": 0.0})]),
            "servo 'jaw': mix weight of 'lips_part' must be a finite non-zero number (got 0)",
        ),
        (
            _toml([_servo(face_max=0.2)]),
            "servo 'jaw': face_min/face_max apply to points only (no points given)",
        ),
        (
            _toml([_servo(**{**POINTS, "face_max": None})]),
            "servo 'jaw': points need face_min and face_max (missing ['face_max'])",
        ),
        (
            _toml([_servo(feature=None, points=[56])]),
            "servo 'jaw': points need face_min and face_max (missing ['face_min', 'face_max'])",
        ),
        (_toml([_servo(gain=0.0)]), "servo 'jaw': gain must be a finite non-zero number (got 0)"),
        (
            _toml([_servo(gain=math.nan)]),
            "servo 'jaw': gain must be a finite non-zero number (got nan)",
        ),
        (
            _toml([_servo(deadband=-0.01)]),
            "servo 'jaw': deadband must be a finite number >= 0 (source units; got -0.01)",
        ),
        (
            _toml([_servo(max_speed=-100)]),
            "servo 'jaw': max_speed must be a finite number >= 0 (µs/s; 0 = unlimited; got -100)",
        ),
        (
            _toml([_servo(max_speed=math.inf)]),
            "servo 'jaw': max_speed must be a finite number >= 0 (µs/s; 0 = unlimited; got inf)",
        ),
        (
            _toml([_servo(max_accel=-1)]),
            "servo 'jaw': max_accel must be a finite number >= 0 (µs/s²; 0 = unlimited; got -1)",
        ),
        (
            _toml(smoothing={"min_cutoff": 0.0}),
            "smoothing.min_cutoff must be a positive number of Hz (got 0)",
        ),
        (
            _toml(smoothing={"d_cutoff": -1.0}),
            "smoothing.d_cutoff must be a positive number of Hz (got -1)",
        ),
        (_toml(smoothing={"beta": -0.5}), "smoothing.beta must be a number >= 0 (got -0.5)"),
        (
            _toml(smoothing={"min_cutoff": math.nan}),
            "smoothing.min_cutoff must be a positive number of Hz (got nan)",
        ),
        (
            _toml([_servo(smoothing={"min_cutoff": 0.0})]),
            "servo 'jaw': smoothing.min_cutoff must be a positive number of Hz (got 0)",
        ),
        (
            _toml(neutral_ramp_s=-0.5),
            "neutral_ramp_s must be a number of seconds >= 0 (got -0.5)",
        ),
        (
            _toml(PAIR, exclusive=[{"servos": ["up", "sideways"]}]),
            "safety.exclusive[0]: unknown servos ['sideways']",
        ),
        (
            _toml(PAIR, exclusive=[{"servos": ["up"]}]),
            "safety.exclusive[0]: needs two or more different servos (got ['up'])",
        ),
        (
            _toml(PAIR, exclusive=[{"servos": ["up", "up"]}]),
            "safety.exclusive[0]: needs two or more different servos (got ['up', 'up'])",
        ),
        (
            _toml(PAIR, exclusive=[{"servos": ["up", "down"], "threshold": 0.0}]),
            "safety.exclusive[0]: threshold 0 is outside (0, 1]",
        ),
        (
            _toml(PAIR, exclusive=[{"servos": ["up", "down"], "threshold": 1.5}]),
            "safety.exclusive[0]: threshold 1.5 is outside (0, 1]",
        ),
        (
            _toml(
                PAIR,
                exclusive=[{"servos": ["up", "down"]}, {"servos": ["down", "up"], "threshold": -1}],
            ),
            "safety.exclusive[1]: threshold -1 is outside (0, 1]",
        ),
        (
            _toml(smoothing={"alpha": 1.0}),
            "Object contains unknown field `alpha` - at `$.smoothing`",
        ),
        (
            _toml([_servo(feature=None, mix={"jaw_open": "lots"})]),
            "servo 'jaw': Expected `float`, got `str` - at `$.servos[0].mix[...]`",
        ),
        (
            _toml([_servo(smoothing={"speed": 2.0})]),
            "servo 'jaw': Object contains unknown field `speed` - at `$.servos[0].smoothing`",
        ),
        (
            _toml(PAIR, exclusive=[{"servos": "up"}]),
            "Expected `array`, got `str` - at `$.safety.exclusive[0].servos`",
        ),
    ],
    ids=[
        "no-source",
        "feature-and-mix",
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
def test_invalid_profiles(text: str, detail: str) -> None:
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "robot.toml")
    message = str(info.value)
    assert message.startswith("robot.toml: ")
    assert detail in message
    assert any(detail in problem for problem in info.value.problems)
    assert all(problem.startswith("robot.toml: ") for problem in info.value.problems)


def test_every_problem_is_listed_separately() -> None:
    text = _toml(
        [
            _servo(feature="jaw_opn", max_speed=-1),
            _servo(name="lip", channel=1, feature=None, mix={}, gain=0.0),
        ],
        smoothing={"beta": -1.0},
        exclusive=[{"servos": ["jaw", "nose"], "threshold": 2.0}],
    )
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "r.toml")
    assert info.value.problems == [
        "r.toml: smoothing.beta must be a number >= 0 (got -1)",
        "r.toml: servo 'jaw': unknown feature 'jaw_opn' (did you mean 'jaw_open'?)",
        "r.toml: servo 'jaw': max_speed must be a finite number >= 0 (µs/s; 0 = unlimited; got -1)",
        "r.toml: servo 'lip': mix is empty (give named features and their weights)",
        "r.toml: servo 'lip': gain must be a finite non-zero number (got 0)",
        "r.toml: safety.exclusive[0]: unknown servos ['nose']",
        "r.toml: safety.exclusive[0]: threshold 2 is outside (0, 1]",
    ]


def test_type_errors_in_several_servos_are_all_listed() -> None:
    text = _toml(
        [_servo(channel="one"), _servo(name="lip", channel=1, max_speed="fast")],
        mirror="yes",
    )
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "r.toml")
    assert info.value.problems == [
        "r.toml: Expected `bool`, got `str` - at `$.mirror`",
        "r.toml: servo 'jaw': Expected `int`, got `str` - at `$.servos[0].channel`",
        "r.toml: servo 'lip': Expected `float`, got `str` - at `$.servos[1].max_speed`",
    ]


# --- describe_source and the command ----------------------------------------------------------


@pytest.mark.parametrize(
    ("servo", "expected"),
    [
        (_servo(), "feature jaw_open"),
        (_servo(**POINTS), "points [56, 57, 58]"),
        (
            _servo(points=[37], face_min=-0.1, face_max=0.1, max_speed=6000, deadband=0.05),
            "feature jaw_open; fallback points [37]; deadband 0.05; max_speed 6000",
        ),
        (
            _servo(feature=None, mix={"lip_corner_pull_right": 1.0, "lips_part": -0.5}, gain=2),
            "mix +1 lip_corner_pull_right, -0.5 lips_part; gain 2",
        ),
    ],
    ids=["feature", "points", "fallback", "mix"],
)
def test_describe_source(servo: dict[str, Any], expected: str) -> None:
    assert describe_source(parse_profile(_toml([servo])).servos[0]) == expected


def test_profile_check_prints_every_problem(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(_toml([_servo(feature="jaw_opn", gain=0.0)], neutral_ramp_s=-1))
    assert main(["profile", "check", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        f"facesynth profile: error: {path}: neutral_ramp_s must be a number of seconds >= 0 "
        "(got -1)",
        f"facesynth profile: error: {path}: servo 'jaw': unknown feature 'jaw_opn' "
        "(did you mean 'jaw_open'?)",
        f"facesynth profile: error: {path}: servo 'jaw': gain must be a finite non-zero number "
        "(got 0)",
    ]


def test_profile_check_missing_file_and_valid_profiles(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["profile", "check", str(tmp_path / "gone.toml")]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"facesynth profile: error: profile file {tmp_path / 'gone.toml'} does not exist"
    ]
    for name, count in (("paper16", 16), ("virtual", 17)):
        assert main(["profile", "check", name]) == 0
        assert capsys.readouterr().out == f"{name}: ok ({count} servos)\n"


def test_profile_show_names_the_sources(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["profile", "show", "virtual"]) == 0
    out = capsys.readouterr().out
    assert "feature jaw_open" in out and "mix +1 lip_corner_pull_left" in out
    assert main(["profile", "show", "paper16"]) == 0
    out = capsys.readouterr().out
    assert "feature gaze_right_y; fallback points [37, 38, 40, 41]" in out
