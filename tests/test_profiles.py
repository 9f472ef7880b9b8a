"""runtime.profiles: the shipped paper16 profile (Table 1) and every way a profile is wrong."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from facesynth.runtime import profiles
from facesynth.runtime.profiles import ProfileError, load_profile, parse_profile

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


@pytest.fixture(autouse=True)
def _isolated(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """No user profiles: HOME is empty and $FACESYNTH_PROFILES is unset."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("FACESYNTH_PROFILES", raising=False)


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    return repr(value) if not isinstance(value, float) or value == value else "nan"


def _servo(**kw: Any) -> dict[str, Any]:
    servo: dict[str, Any] = dict(
        name="jaw",
        channel=0,
        points=[56, 57, 58],
        min_us=1000,
        neutral_us=1500,
        max_us=2000,
        face_min=-0.1,
        face_max=0.2,
    )
    servo.update(kw)
    return servo


def _toml(servos: list[dict[str, Any]] | None = None, **top: Any) -> str:
    head: dict[str, Any] = {"name": "test"}
    head.update(top)
    lines = [f"{key} = {_value(value)}" for key, value in head.items()]
    for servo in [_servo()] if servos is None else servos:
        lines.append("[[servos]]")
        lines.extend(f"{key} = {_value(value)}" for key, value in servo.items())
    return "\n".join(lines) + "\n"


# --- the shipped profile ----------------------------------------------------------------------


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


def test_paper16_by_name_and_by_path_agree() -> None:
    path = profiles.PACKAGE_DIR / "paper16.toml"
    assert profiles.resolve_profile("paper16") == path
    assert load_profile(str(path)) == load_profile("paper16")
    assert "paper16" in profiles.available_profiles()


def test_servo_lookup() -> None:
    profile = load_profile("paper16")
    assert profile.servo("jaw").channel == 11
    with pytest.raises(KeyError):
        profile.servo("tail")


# --- valid variations -------------------------------------------------------------------------


def test_minimal_profile_and_defaults() -> None:
    profile = parse_profile(_toml())
    assert profile.name == "test"
    assert profile.mirror is False and profile.neutral_seconds == 1.0
    (servo,) = profile.servos
    assert servo.reversed is False and servo.description == ""
    assert (servo.min_us, servo.neutral_us, servo.max_us) == (1000, 1500, 2000)


@pytest.mark.parametrize(
    "servo",
    [
        _servo(min_us=900, neutral_us=900, max_us=2100),
        _servo(min_us=900, neutral_us=2100, max_us=2100),
        _servo(points=[0, 67]),
        _servo(channel=0, min_us=0),
    ],
    ids=["neutral-at-min", "neutral-at-max", "first-and-last-point", "zero-min"],
)
def test_edge_values_are_valid(servo: dict[str, Any]) -> None:
    assert parse_profile(_toml([servo])).servos[0].points == servo["points"]


# --- invalid profiles: one table, one precise message each ------------------------------------


@pytest.mark.parametrize(
    ("text", "detail"),
    [
        ('name = "x"\n[[servos]\n', "not valid TOML"),
        ("name = \n", "not valid TOML"),
        (_toml(colour="red"), "Object contains unknown field `colour`"),
        (_toml([_servo(speed=3)]), "Object contains unknown field `speed` - at `$.servos[0]`"),
        ('name = "x"\n', "Object missing required field `servos`"),
        (
            _toml([{k: v for k, v in _servo().items() if k != "max_us"}]),
            "Object missing required field `max_us` - at `$.servos[0]`",
        ),
        (_toml([_servo(channel="zero")]), "Expected `int`, got `str` - at `$.servos[0].channel`"),
        (_toml([_servo(points=18)]), "Expected `array`, got `int` - at `$.servos[0].points`"),
        (_toml(mirror="yes"), "Expected `bool`, got `str` - at `$.mirror`"),
        (_toml(name=""), "name is empty"),
        (_toml(scheme="mesh468"), "scheme 'mesh468' is not supported (use 'ibug68')"),
        (_toml(neutral_seconds=0), "neutral_seconds must be a positive number"),
        (_toml(neutral_seconds=-1.0), "neutral_seconds must be a positive number"),
        (_toml(neutral_seconds=float("nan")), "neutral_seconds must be a positive number"),
        ('name = "x"\nservos = []\n', "no servos"),
        (_toml([_servo(name="")]), "a servo has an empty name"),
        (_toml([_servo(), _servo(channel=1)]), "servo 'jaw' is defined twice"),
        (_toml([_servo(), _servo(name="lip")]), "servo 'lip': channel 0 is used twice"),
        (_toml([_servo(channel=-1)]), "servo 'jaw': channel -1 is negative"),
        (
            _toml([_servo(min_us=2100)]),
            "servo 'jaw': needs min_us <= neutral_us <= max_us and min_us < max_us "
            "(got 2100, 1500, 2000)",
        ),
        (_toml([_servo(neutral_us=2500)]), "(got 1000, 2500, 2000)"),
        (_toml([_servo(neutral_us=900)]), "(got 1000, 900, 2000)"),
        (
            _toml([_servo(min_us=1500, neutral_us=1500, max_us=1500)]),
            "min_us < max_us (got 1500, 1500, 1500)",
        ),
        (_toml([_servo(min_us=-10, neutral_us=0)]), "servo 'jaw': min_us -10 is negative"),
        (_toml([_servo(face_min=0)]), "servo 'jaw': needs face_min < 0 < face_max (got 0, 0.2)"),
        (_toml([_servo(face_min=0.05)]), "needs face_min < 0 < face_max (got 0.05, 0.2)"),
        (_toml([_servo(face_max=0)]), "needs face_min < 0 < face_max (got -0.1, 0)"),
        (_toml([_servo(face_max=-0.2)]), "needs face_min < 0 < face_max (got -0.1, -0.2)"),
        (
            _toml([_servo(max_us=float("nan"))]),
            "servo 'jaw': limits and ranges must be finite numbers",
        ),
        (_toml([_servo(face_max=float("inf"))]), "limits and ranges must be finite numbers"),
        (_toml([_servo(points=[])]), "servo 'jaw': no points"),
        (_toml([_servo(points=[56, 68])]), "servo 'jaw': points [68] are outside 0..67"),
        (_toml([_servo(points=[-1, 30, 99])]), "points [-1, 99] are outside 0..67"),
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
        "no-points",
        "point-68",
        "points-negative-and-99",
    ],
)
def test_invalid_profiles(text: str, detail: str) -> None:
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "robot.toml")
    message = str(info.value)
    assert message.startswith("robot.toml: ")
    assert detail in message


def test_every_problem_is_reported_at_once() -> None:
    text = _toml([_servo(channel=-1, points=[70]), _servo(face_max=0)], scheme="x")
    with pytest.raises(ProfileError) as info:
        parse_profile(text)
    message = str(info.value)
    for detail in (
        "scheme 'x'",
        "channel -1 is negative",
        "points [70]",
        "defined twice",
        "face_min < 0 < face_max",
    ):
        assert detail in message
    assert message.count("; ") >= 4


# --- finding and reading profile files --------------------------------------------------------


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "gone.toml"
    with pytest.raises(ProfileError, match=f"profile file {re.escape(str(path))} does not exist"):
        load_profile(str(path))


def test_missing_file_given_as_path_without_suffix(tmp_path: Path) -> None:
    path = tmp_path / "robots" / "gone"
    with pytest.raises(ProfileError, match="does not exist"):
        load_profile(str(path))


def test_unknown_name_lists_available_profiles(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    extra = tmp_path / "extra"
    extra.mkdir()
    (extra / "alyx.toml").write_text(_toml(name="alyx"))
    monkeypatch.setenv("FACESYNTH_PROFILES", str(extra))
    with pytest.raises(ProfileError) as info:
        load_profile("nope")
    assert str(info.value) == "no profile named 'nope' (available: alyx, head16, paper16, virtual)"


def test_non_utf8_file(tmp_path: Path) -> None:
    path = tmp_path / "latin1.toml"
    path.write_bytes(_toml(description="caf\xe9").encode("latin-1"))
    with pytest.raises(ProfileError, match=f"cannot read profile {re.escape(str(path))}: .*utf-8"):
        load_profile(str(path))


def test_invalid_file_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text(_toml([_servo(points=[80])]))
    where = re.escape(str(path))
    with pytest.raises(ProfileError, match=f"^{where}: servo 'jaw': points \\[80\\]"):
        load_profile(str(path))


def test_search_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    env_dir = tmp_path / "env"
    env_dir.mkdir()
    home_dir = tmp_path / "home" / ".config" / "facesynth" / "profiles"
    home_dir.mkdir(parents=True)
    (home_dir / "paper16.toml").write_text(_toml(name="paper16", description="home"))
    assert load_profile("paper16").description == "home"  # home beats the package
    (env_dir / "paper16.toml").write_text(_toml(name="paper16", description="env"))
    monkeypatch.setenv("FACESYNTH_PROFILES", str(env_dir))
    assert load_profile("paper16").description == "env"  # $FACESYNTH_PROFILES beats home
    assert profiles.PROFILES.search_dirs()[:2] == [env_dir, home_dir]
    assert profiles.PROFILES.search_dirs()[-1] == profiles.PACKAGE_DIR
