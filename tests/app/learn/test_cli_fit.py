"""The one call from ``facesynth learn`` into the fitting: a session's poses in, the learned
profile written, the report out (the fitting itself is tested with it, in test_fit*.py)."""

from __future__ import annotations

import sys
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from facesynth.app.learn import cli
from facesynth.app.learn.dataset import BabbleSet
from facesynth.runtime import profiles
from facesynth.runtime.profiles import Profile, load_profile


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
