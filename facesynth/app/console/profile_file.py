"""A profile as TOML, and saving it the way the console does: validated, atomic, with a backup.

:func:`profile_toml` writes every field that differs from its default (and every required one),
so :func:`~facesynth.runtime.profiles.parse_profile` reads back exactly the same profile;
:func:`save_profile` checks that it does before anything is written, keeps the previous file as
``NAME.toml.bak`` and replaces the file atomically (a kill leaves the old file or the new one).
"""

from __future__ import annotations

import datetime
from pathlib import Path
from typing import Any

import msgspec

from facesynth.app.toml_text import toml_value
from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.profiles import (
    PACKAGE_DIR,
    PROFILES,
    Profile,
    ProfileError,
    ServoSpec,
    parse_profile,
)

_TOP = ("name", "description", "scheme", "mirror", "neutral_seconds", "neutral_ramp_s")
_TOP_MORE = ("max_command_age_s",)


def _defaults(struct: type[msgspec.Struct]) -> dict[str, Any]:
    values: dict[str, Any] = {}
    for field in msgspec.structs.fields(struct):
        if field.default is not msgspec.NODEFAULT:
            values[field.name] = field.default
        elif field.default_factory is not msgspec.NODEFAULT:
            values[field.name] = field.default_factory()
    return values


def _pairs(data: dict[str, Any], defaults: dict[str, Any], keep: tuple[str, ...] = ()) -> list[str]:
    lines = []
    for key, value in data.items():
        if value is None or (key not in keep and key in defaults and value == defaults[key]):
            continue
        lines.append(f"{key} = {toml_value(value)}")
    return lines


def profile_toml(profile: Profile, header: str = "") -> str:
    """``profile`` as the TOML text of a profile file (a learned profile is refused)."""
    if profile.learned is not None:
        raise ProfileError(f"profile {profile.name!r} is learned: it is not written as TOML")
    data = msgspec.to_builtins(profile)
    defaults = _defaults(Profile)
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    top = {key: data[key] for key in (*_TOP, *_TOP_MORE)}
    lines += _pairs(top, defaults, keep=("name",))
    if data.get("smoothing") is not None:
        lines += ["", "[smoothing]"]
        lines += [f"{k} = {toml_value(v)}" for k, v in data["smoothing"].items()]
    for rule in data["safety"]["exclusive"]:
        lines += ["", "[[safety.exclusive]]"]
        lines += [f"{k} = {toml_value(v)}" for k, v in rule.items()]
    servo_defaults = _defaults(ServoSpec)
    required = ("name", "channel", "min_us", "neutral_us", "max_us")
    for servo in data["servos"]:
        if servo.get("smoothing") is not None:
            servo["smoothing"] = {k: v for k, v in servo["smoothing"].items() if v is not None}
        lines += ["", "[[servos]]"]
        lines += _pairs(servo, servo_defaults, keep=required)
    return "\n".join(lines) + "\n"


def save_path(source: Path | None, name: str) -> Path:
    """Where the console saves a profile loaded from ``source``: the same file, unless it is
    one shipped with facesynth; then the user's profile folder (found first by name)."""
    if source is not None and source.suffix == ".toml":
        try:
            shipped = source.resolve().parent == Path(PACKAGE_DIR).resolve()
        except OSError:
            shipped = False
        if not shipped:
            return source
    return PROFILES.search_dirs()[-2] / f"{name}.toml"  # ~/.config/facesynth/profiles


def backup_path(path: Path) -> Path:
    """Where the previous version of ``path`` is kept."""
    return path.with_name(path.name + ".bak")


def save_profile(
    profile: Profile, path: Path, *, now: datetime.datetime | None = None
) -> Path | None:
    """Write ``profile`` to ``path`` (validated, read back identical, atomically; the previous
    file kept as ``PATH.bak``); returns the backup's path (``None``: there was no previous
    file). ``ProfileError`` when the profile is not valid; nothing is written then."""
    stamp = (now or datetime.datetime.now(datetime.UTC)).isoformat(timespec="seconds")
    header = (
        f"{profile.name}: written by facesynth console at {stamp}.\n"
        f"The previous version of this file, if any, is {backup_path(path).name}."
    )
    text = profile_toml(profile, header)
    again = parse_profile(text, str(path))  # every problem, as `profile check` says it
    if again != profile:
        raise ProfileError(f"{path}: the written profile would not read back the same")
    backup = None
    if path.exists():
        backup = write_atomic(backup_path(path), path.read_bytes(), mode=0o644)
    write_atomic(path, text, mode=0o644)
    return backup
