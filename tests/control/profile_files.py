"""Profiles written for the driver tests."""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path


def write_profile(path: Path, servos: list[dict[str, object]], name: str = "testface") -> Path:
    """A profile TOML file: each servo a dict of ServoSpec fields (a points source is added)."""
    lines = [f'name = "{name}"', "neutral_ramp_s = 0.2", ""]
    for servo in servos:
        lines.append("[[servos]]")
        fields = {"points": [48], "face_min": -0.1, "face_max": 0.1, **servo}
        for key, value in fields.items():
            text = (
                f'"{value}"'
                if isinstance(value, str)
                else str(value).lower()
                if isinstance(value, bool)
                else str(value)
            )
            lines.append(f"{key} = {text}")
        lines.append("")
    path.write_text("\n".join(lines))
    return path


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
