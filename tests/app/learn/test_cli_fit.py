"""The one call from ``facesynth learn`` into the fitting: a session's poses in, the learned
profile written, the report out (the fitting itself is tested with it, in test_fit*.py)."""

from __future__ import annotations

import sys
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from facesynth.app.cli import main
from facesynth.app.learn import cli
from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.session import metadata
from facesynth.app.recording.layout import Layout
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import codec, profiles
from facesynth.runtime.profiles import Profile, load_profile
from schemas.messages import BabbleSample


def _babble(profile: Profile) -> BabbleSet:
    servos = tuple(spec.name for spec in profile.servos)
    commands = np.array([list(profile.neutral_positions().values())] * 2)
    return BabbleSet(servos, commands, ("a",), np.zeros((2, 1)), ("neutral", "random"))


def test_the_fitting_is_called_and_its_profile_saved(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[Any] = []
    fake = types.ModuleType("facesynth.app.learn.fit")
    fake.fit_learned_profile = lambda babble, profile: calls.append(len(babble)) or profile  # type: ignore[attr-defined]
    fake.format_report = lambda profile: f"report of {profile.name}"  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "facesynth.app.learn.fit", fake)
    monkeypatch.setattr(
        profiles, "save_learned_profile", lambda p, path: calls.append(path) or path, raising=False
    )
    profile = load_profile("paper16")
    out = tmp_path / "head.learned"
    assert cli.fit(_babble(profile), profile, out) == f"report of paper16\nwrote {out}"
    assert calls == [2, out]


def test_without_the_fitting_the_poses_are_kept_for_later(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "facesynth.app.learn.fit", None)
    profile = load_profile("paper16")
    with pytest.raises(cli.LearnError, match=r"2 poses of paper16 kept.*--fit-only"):
        cli.fit(_babble(profile), profile, Path("x.learned"))


def _session(path: Path, poses: int) -> None:
    profile = load_profile("paper16")
    writer = SessionWriter(path, metadata=metadata("self", profile, 0, ["babble"]))
    for seq in range(poses):
        sample = BabbleSample(
            seq=seq,
            t_capture_ns=seq,
            t_media_ns=seq,
            profile="paper16",
            kind="random",
            commanded=profile.neutral_positions(),
            features={"a": 0.1 * seq},
        )
        for entry in Layout().entries("facesynth/self/babble", codec.encode(sample), seq, seq):
            writer.write(entry)
    writer.close()


def _fake_fitting(monkeypatch: pytest.MonkeyPatch, seen: list[int]) -> None:
    fake = types.ModuleType("facesynth.app.learn.fit")
    fake.fit_learned_profile = lambda babble, profile: seen.append(len(babble)) or profile  # type: ignore[attr-defined]
    fake.format_report = lambda profile: "held-out report"  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "facesynth.app.learn.fit", fake)
    monkeypatch.setattr(profiles, "save_learned_profile", lambda p, path: path, raising=False)


def test_a_complete_session_is_fitted_without_babbling(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    seen: list[int] = []
    _fake_fitting(monkeypatch, seen)
    path = tmp_path / "s.mcap"
    _session(path, 3)
    argv = ["learn", "--profile", "paper16", "--out", str(path), "--poses", "2", "--video", "x"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert f"{path} already holds 3 poses (--poses 2): nothing to babble" in out
    assert "held-out report" in out and f"wrote {tmp_path / 's.learned'}" in out
    # --fit-only takes the session's own profile
    target = tmp_path / "head.learned"
    assert main(["learn", "--fit-only", str(path), "--out-profile", str(target)]) == 0
    assert f"wrote {target}" in capsys.readouterr().out
    assert seen == [3, 3]
