"""runtime.profiles.loading: profile files by name or path, read, parsed, every problem reported."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from profile_toml import feature_servo, points_servo, points_toml, profile_toml

from facesynth.runtime import profiles
from facesynth.runtime.profiles import ProfileError, load_profile, parse_profile

# --- finding and reading profile files ------------------------------------------------------------


def test_paper16_by_name_and_by_path_agree() -> None:
    path = profiles.PACKAGE_DIR / "paper16.toml"
    assert profiles.resolve_profile("paper16") == path
    assert load_profile(str(path)) == load_profile("paper16")
    assert "paper16" in profiles.available_profiles()


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
    (extra / "alyx.toml").write_text(points_toml(name="alyx"))
    monkeypatch.setenv("FACESYNTH_PROFILES", str(extra))
    with pytest.raises(ProfileError) as info:
        load_profile("nope")
    shipped = sorted(path.stem for path in profiles.PACKAGE_DIR.glob("*.toml"))
    assert {"head16", "paper16", "virtual", "arkit52"} <= set(shipped)
    available = ", ".join(sorted(["alyx", *shipped]))
    assert str(info.value) == f"no profile named 'nope' (available: {available})"


def test_non_utf8_file(tmp_path: Path) -> None:
    path = tmp_path / "latin1.toml"
    path.write_bytes(points_toml(description="caf\xe9").encode("latin-1"))
    with pytest.raises(ProfileError, match=f"cannot read profile {re.escape(str(path))}: .*utf-8"):
        load_profile(str(path))


def test_invalid_file_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text(points_toml([points_servo(points=[80])]))
    where = re.escape(str(path))
    with pytest.raises(ProfileError, match=f"^{where}: servo 'jaw': points \\[80\\]"):
        load_profile(str(path))


def test_search_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    env_dir = tmp_path / "env"
    env_dir.mkdir()
    home_dir = tmp_path / "home" / ".config" / "facesynth" / "profiles"
    home_dir.mkdir(parents=True)
    (home_dir / "paper16.toml").write_text(points_toml(name="paper16", description="home"))
    assert load_profile("paper16").description == "home"  # home beats the package
    (env_dir / "paper16.toml").write_text(points_toml(name="paper16", description="env"))
    monkeypatch.setenv("FACESYNTH_PROFILES", str(env_dir))
    assert load_profile("paper16").description == "env"  # $FACESYNTH_PROFILES beats home
    assert profiles.PROFILES.search_dirs()[:2] == [env_dir, home_dir]
    assert profiles.PROFILES.search_dirs()[-1] == profiles.PACKAGE_DIR


# --- every problem of a profile, at once ----------------------------------------------------------


def test_every_problem_is_reported_at_once() -> None:
    text = points_toml(
        [points_servo(channel=-1, points=[70]), points_servo(face_max=0)], scheme="x"
    )
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


def test_every_problem_is_listed_separately() -> None:
    text = profile_toml(
        [
            feature_servo(feature="jaw_opn", max_speed=-1),
            feature_servo(name="lip", channel=1, feature=None, mix={}, gain=0.0),
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
    text = profile_toml(
        [feature_servo(channel="one"), feature_servo(name="lip", channel=1, max_speed="fast")],
        mirror="yes",
    )
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "r.toml")
    assert info.value.problems == [
        "r.toml: Expected `bool`, got `str` - at `$.mirror`",
        "r.toml: servo 'jaw': Expected `int`, got `str` - at `$.servos[0].channel`",
        "r.toml: servo 'lip': Expected `float`, got `str` - at `$.servos[1].max_speed`",
    ]


def test_an_unknown_key_with_a_newline_stays_on_one_line() -> None:
    """msgspec quotes an unknown key as it is (found by tests/fuzz)."""
    text = (Path(profiles.PACKAGE_DIR) / "paper16.toml").read_text() + '\n"bad\\nkey" = 1\n'
    with pytest.raises(ProfileError, match=r"bad\\nkey") as info:
        parse_profile(text)
    assert "\n" not in str(info.value)


SERVO_TABLE = 'channel = 0\nfeature = "jaw_open"\nmin_us = 1000\nneutral_us = 1500\nmax_us = 2000\n'


@pytest.mark.parametrize(
    ("text", "line", "shown"),
    [
        ('name = "r"\n\n[servos.jaw]\n' + SERVO_TABLE, 3, "[servos.jaw]"),
        ('name = "r"\n[servos]\n[servos.jaw]\n' + SERVO_TABLE, 2, "[servos.jaw]"),
        ('name = "r"\nservos = { jaw = { channel = 0 } }\n', 2, "[servos.jaw]"),
        ('name = "r"\nservos.jaw.channel = 0\n', 2, "[servos.jaw]"),
        (
            'name = "r"\n[[safety.exclusive]]\nservos = ["a", "b"]\n\n[servos]\njaw = 1\n',
            5,
            "[servos]",
        ),
    ],
)
def test_servos_written_as_a_table_name_the_array_of_tables_and_the_line(
    text: str, line: int, shown: str
) -> None:
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "r.toml")
    assert f"r.toml: line {line}: servos are written as [[servos]] tables" in str(info.value)
    assert f"not as {shown} - at `$.servos`" in str(info.value)
    assert "Expected `array`" not in str(info.value)
    assert "\n" not in str(info.value)


def test_servos_as_a_table_and_other_problems_are_all_listed() -> None:
    text = 'name = "r"\nmirror = "yes"\n[servos.jaw]\n' + SERVO_TABLE
    with pytest.raises(ProfileError) as info:
        parse_profile(text, "r.toml")
    assert info.value.problems == [
        "r.toml: line 3: servos are written as [[servos]] tables (an array of tables, one per "
        'servo, each with its name = "…"), not as [servos.jaw] - at `$.servos`',
        "r.toml: Expected `bool`, got `str` - at `$.mirror`",
    ]
