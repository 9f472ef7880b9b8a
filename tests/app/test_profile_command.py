"""``facesynth profile check|show``: every problem on its own error line, the sources shown."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.cli import main

pytestmark = pytest.mark.usefixtures("isolated_home")  # the shipped profiles only


BAD_PROFILE = """\
name = "test"
neutral_ramp_s = -1
[[servos]]
name = "jaw"
channel = 0
min_us = 1000
neutral_us = 1500
max_us = 2000
feature = "jaw_opn"
gain = 0.0
"""


def test_profile_check_prints_every_problem(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(BAD_PROFILE)
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
