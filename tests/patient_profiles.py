"""Shipped profiles made patient about command age, for tests that count every command."""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path


def patient_profile(path: Path, shipped: str = "paper16", age_s: float = 5.0) -> Path:
    """A shipped profile that lets commands age ``age_s`` before C drops them as stale (its
    default 0.25 s): for tests that count every command of a real-time run, where a stall of
    a loaded machine would make C drop one, as it should (the age rule has tests of its own:
    tests/control/test_control_freshness.py, tests/runtime/test_capture_age.py,
    tests/faults/test_stale_commands.py)."""
    text = resources.files("facesynth.runtime.profiles").joinpath(f"{shipped}.toml").read_text()
    line = rf"\1\nmax_command_age_s = {age_s}"
    patched, found = re.subn(r"(?m)^(name = .*)$", line, text, count=1)
    assert found == 1 and "max_command_age_s" not in text, f"{shipped}: no name line to patch"
    path.write_text(patched)
    return path
