"""Profiles written for the driver tests."""

from __future__ import annotations

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
