"""``facesynth profile list|check|show`` with hardware-only and learned profiles."""

from __future__ import annotations

from pathlib import Path

import msgspec
import numpy as np
import pytest

from facesynth.app.cli import main
from facesynth.runtime.profiles import Learned, load_profile, save_learned_profile
from facesynth.runtime.profiles.learned import PolyRidge, Report, pack

pytestmark = pytest.mark.usefixtures("isolated_home")


def _learned_file(folder: Path) -> Path:
    hardware = load_profile("head16_hardware")
    specs = hardware.servos[:3]
    learned = Learned(
        inputs=["jaw_open"],
        reach_low=pack(np.array([-0.05])),
        reach_high=pack(np.array([0.2])),
        input_mean=pack(np.zeros(1)),
        input_scale=pack(np.ones(1)),
        outputs=["right_eyebrow", "left_eyebrow"],
        dead=["middle_eyebrow"],
        inverse=PolyRidge(
            degree=1,
            powers=pack(np.eye(1)),
            coef=pack(np.ones((2, 1))),
            intercept=pack(np.zeros(2)),
        ),
        report=Report(
            model="poly_ridge",
            servo_error={"right_eyebrow": 0.031, "left_eyebrow": 0.0},
            candidates={"poly_ridge": 0.0155},
            samples=321,
            held_out=64,
        ),
    )
    profile = msgspec.structs.replace(hardware, name="robot", servos=specs, learned=learned)
    return save_learned_profile(profile, folder / "robot.learned")


def test_list_check_and_show_a_learned_profile(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _learned_file(tmp_path)
    monkeypatch.setenv("FACESYNTH_PROFILES", str(tmp_path))
    assert main(["profile", "list"]) == 0
    assert "robot" in capsys.readouterr().out.split()
    assert main(["profile", "check", "robot"]) == 0
    assert capsys.readouterr().out == (
        "robot: ok (3 servos; learned: poly_ridge from 1 inputs to 2 servos (1 dead), held-out "
        "error 0.015 of range (worst 0.031), 321 samples)\n"
    )
    assert main(["profile", "show", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("learned: poly_ridge")
    assert lines[1].split() == ["ch", "servo", "min_us", "neutral", "max_us", "reversed", "source"]
    assert lines[2].split() == [
        "0",
        "right_eyebrow",
        "1000",
        "1500",
        "2000",
        "learned:",
        "held-out",
        "error",
        "0.031",
        "of",
        "range",
    ]
    assert lines[3].endswith("learned: held-out error 0.000 of range")
    assert lines[4].endswith("learned: dead, kept at neutral")


def test_check_a_hardware_profile_and_a_broken_learned_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["profile", "check", "head16_hardware"]) == 0
    assert capsys.readouterr().out == (
        "head16_hardware: ok (16 servos; hardware only: no sources, for facesynth learn and "
        "control)\n"
    )
    broken = tmp_path / "broken.learned"
    broken.write_bytes(_learned_file(tmp_path).read_bytes()[:100])
    assert main(["profile", "check", str(broken)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"facesynth profile: error: {broken}: not a learned profile (not msgpack: Input data "
        "was truncated)"
    ]
    assert main(["profile", "show", str(broken)]) == 2
    assert "not a learned profile" in capsys.readouterr().err


def test_the_fit_module_reports_and_times_t(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from facesynth.app.learn.fit import main as fit_main

    assert fit_main([str(_learned_file(tmp_path)), "--frames", "20"]) == 0
    out = capsys.readouterr().out
    assert "robot: poly_ridge from 1 inputs, 321 samples" in out
    assert "  middle_eyebrow       dead (kept at neutral)" in out
    assert out.splitlines()[-1].startswith("T: ") and out.endswith(" ms per frame\n")
