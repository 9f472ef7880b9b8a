"""Profiles by name: finding the TOML file, parsing it and reporting every problem at once.

Lookup order for a name: a path to an existing file; ``$FACESYNTH_PROFILES``;
``~/.config/facesynth/profiles``; the profiles shipped in this package.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import msgspec

from facesynth.runtime.named_files import NamedFiles
from facesynth.runtime.oneline import one_line

from .model import Profile, ServoSpec
from .validation import validate_profile

PACKAGE_DIR = Path(__file__).parent


class ProfileError(ValueError):
    """A profile that cannot be used; the message names the file and what is wrong.

    ``problems`` lists every problem found (the message joins them with ``"; "``).
    """

    def __init__(self, message: str, problems: list[str] | None = None) -> None:
        super().__init__(message)
        self.problems: list[str] = problems if problems is not None else [message]


PROFILES = NamedFiles("profile", ".toml", "FACESYNTH_PROFILES", PACKAGE_DIR, list_available=True)


def available_profiles() -> list[str]:
    """Names of every profile found in the search folders."""
    return PROFILES.available()


def resolve_profile(name_or_path: str) -> Path:
    """The file a profile name or path refers to, or raise :class:`ProfileError`."""
    try:
        return PROFILES.resolve(name_or_path)
    except LookupError as exc:
        raise ProfileError(str(exc)) from None


def parse_profile(text: str, source: str = "<profile>") -> Profile:
    """Parse and validate profile TOML text; :class:`ProfileError` lists every problem."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise _error(source, [f"not valid TOML: {exc}"]) from None
    try:
        profile = msgspec.convert(data, Profile)
    except msgspec.ValidationError as exc:
        raise _error(source, _structure_problems(data, exc)) from None
    problems = validate_profile(profile)
    if problems:
        raise _error(source, problems)
    return profile


def _error(source: str, problems: list[str]) -> ProfileError:
    problems = [one_line(p) for p in problems]
    return ProfileError(f"{source}: " + "; ".join(problems), [f"{source}: {p}" for p in problems])


def _at(message: str, path: str) -> str:
    """A msgspec message about a sub-object, with its path inside the whole profile."""
    if " - at `$" in message:
        return message.replace(" - at `$", f" - at `{path}", 1)
    return f"{message} - at `{path}`"


def _structure_problems(data: dict[str, Any], whole: msgspec.ValidationError) -> list[str]:
    """Every type/shape error of the profile: the top level and each servo converted apart."""
    problems: list[str] = []
    servos = data.get("servos")
    top = dict(data)
    if isinstance(servos, list):
        top["servos"] = []
    try:
        msgspec.convert(top, Profile)
    except msgspec.ValidationError as exc:
        problems.append(str(exc))
    if isinstance(servos, list):
        for index, servo in enumerate(servos):
            try:
                msgspec.convert(servo, ServoSpec)
            except msgspec.ValidationError as exc:
                name = servo.get("name") if isinstance(servo, dict) else None
                where = f"servo {name!r}: " if isinstance(name, str) else ""
                problems.append(where + _at(str(exc), f"$.servos[{index}]"))
    return problems or [str(whole)]


def load_profile(name_or_path: str) -> Profile:
    """Load a profile by name or path, validated."""
    path = resolve_profile(name_or_path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProfileError(f"cannot read profile {path}: {exc}") from None
    return parse_profile(text, str(path))
