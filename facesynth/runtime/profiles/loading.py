"""Profiles by name: finding the file, parsing it and reporting every problem at once.

Lookup order for a name: a path to an existing file; ``$FACESYNTH_PROFILES``;
``~/.config/facesynth/profiles``; the profiles shipped in this package. In each folder
``NAME.toml`` (a written profile) comes before ``NAME.learned`` (a learned profile,
:mod:`.learned_file`).
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path
from typing import Any

import msgspec

from facesynth.runtime.named_files import NamedFiles
from facesynth.runtime.oneline import one_line

from .learned import Regional
from .learned_file import (
    FORMAT,
    REGIONAL_SINCE,
    SUFFIX,
    VERSIONS,
    Header,
    LearnedFile,
    split_file,
)
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


def available_profiles(*, hardware: bool = False) -> list[str]:
    """Names of the profiles found in the search folders that a chain can run (written and
    learned ones); with ``hardware``, also those with servos without a source (hardware
    profiles, for ``facesynth learn`` and the control interface: the translator refuses them)."""
    dirs = [d for d in PROFILES.search_dirs() if d.is_dir()]
    learned = {p.stem for d in dirs for p in d.glob(f"*{SUFFIX}")}
    written = set(PROFILES.available())
    if not hardware:
        written = {name for name in written if not _hardware_only(resolve_profile(name))}
    return sorted(written | learned)


def _hardware_only(path: Path) -> bool:
    """Whether a TOML profile has a servo without a source (unreadable files: no)."""
    try:
        servos = tomllib.loads(path.read_text(encoding="utf-8")).get("servos")
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False
    sources = ("points", "feature", "blendshape", "mix")
    return isinstance(servos, list) and any(
        isinstance(servo, dict) and not any(servo.get(key) for key in sources) for servo in servos
    )


def resolve_profile(name_or_path: str) -> Path:
    """The file a profile name or path refers to, or raise :class:`ProfileError`."""
    if Path(name_or_path).suffix == SUFFIX or os.sep in name_or_path:
        if Path(name_or_path).is_file():
            return Path(name_or_path)
        raise ProfileError(f"profile file {name_or_path} does not exist")
    if Path(name_or_path).suffix != PROFILES.suffix:
        for folder in PROFILES.search_dirs():
            for suffix in (PROFILES.suffix, SUFFIX):
                path = folder / f"{name_or_path}{suffix}"
                if path.is_file():
                    return path
        raise ProfileError(
            f"no profile named {name_or_path!r} "
            f"(available: {', '.join(available_profiles(hardware=True)) or 'none'})"
        )
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
    if "learned" in data:
        raise _error(source, ["learned: only a learned profile file (NAME.learned) has one"])
    try:
        profile = msgspec.convert(data, Profile)
    except msgspec.ValidationError as exc:
        raise _error(source, _structure_problems(data, exc, text)) from None
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


_HEADER = re.compile(r"^\s*\[")
_SERVOS_KEY = re.compile(r"""^\s*(servos|"servos"|'servos')\s*[.=]""")
_SERVOS_TABLE = re.compile(r"""^\s*\[\s*(servos|"servos"|'servos')\s*[.\]]""")


def _servos_line(text: str) -> int | None:
    """The line (1-based) where ``servos`` is first made a table: a ``[servos.NAME]`` or
    ``[servos]`` header, or a ``servos = {…}`` / ``servos.NAME…`` key before any header."""
    at_root = True
    for number, line in enumerate(text.splitlines(), start=1):
        if _SERVOS_TABLE.match(line) and not line.lstrip().startswith("[["):
            return number
        if _HEADER.match(line):
            at_root = False
        elif at_root and _SERVOS_KEY.match(line):
            return number
    return None


def _servos_as_table(text: str, servos: dict[str, Any]) -> str:
    """The problem of a profile whose servos are a table (``[servos.jaw]``), not an array of
    tables (``[[servos]]``), with the line where it starts."""
    tables = [name for name, value in servos.items() if isinstance(value, dict)]
    shown = f"[servos.{tables[0]}]" if tables else "[servos]"
    number = _servos_line(text)
    where = f"line {number}: " if number is not None else ""
    return (
        f"{where}servos are written as [[servos]] tables (an array of tables, one per servo, "
        f'each with its name = "…"), not as {shown} - at `$.servos`'
    )


def _structure_problems(
    data: dict[str, Any], whole: msgspec.ValidationError, text: str
) -> list[str]:
    """Every type/shape error of the profile: the top level and each servo converted apart."""
    problems: list[str] = []
    servos = data.get("servos")
    top = dict(data)
    if isinstance(servos, list):
        top["servos"] = []
    elif isinstance(servos, dict):
        top["servos"] = []
        problems.append(_servos_as_table(text, servos))
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


def parse_learned_profile(data: bytes, source: str = "<learned profile>") -> Profile:
    """Read and check a learned profile file's bytes; :class:`ProfileError` (one line) when
    it is not msgpack, not a learned profile, of another version, or malformed in any part."""
    try:
        header = msgspec.msgpack.decode(data, type=Header)
    except msgspec.ValidationError as exc:  # msgpack, but not a map
        raise _error(source, [f"not a learned profile ({exc})"]) from None
    except (msgspec.DecodeError, UnicodeDecodeError) as exc:  # a string that is not UTF-8
        raise _error(source, [f"not a learned profile (not msgpack: {exc})"]) from None
    if header.format != FORMAT:
        raise _error(source, [f"not a learned profile (format {header.format!r}, not {FORMAT!r})"])
    if type(header.version) is not int or header.version not in VERSIONS:
        reads = ", ".join(map(str, VERSIONS))
        raise _error(
            source,
            [f"learned profile version {header.version!r} is not supported (this reads {reads})"],
        )
    try:
        document = msgspec.msgpack.decode(data, type=LearnedFile)
    except (msgspec.DecodeError, msgspec.ValidationError, UnicodeDecodeError) as exc:
        raise _error(source, [f"malformed learned profile: {exc}"]) from None
    if document.profile.learned is not None:
        raise _error(source, ["profile.learned: the hardware profile holds no mapping"])
    if isinstance(document.inverse, Regional) and document.version < REGIONAL_SINCE:
        raise _error(
            source,
            [f"inverse: a regional model needs version {REGIONAL_SINCE} (not {document.version})"],
        )
    profile = split_file(document)
    problems = validate_profile(profile)
    if problems:
        raise _error(source, problems)
    return profile


def load_profile(name_or_path: str) -> Profile:
    """Load a profile (written ``.toml`` or learned ``.learned``) by name or path, validated."""
    path = resolve_profile(name_or_path)
    if path.suffix == SUFFIX:
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise ProfileError(f"cannot read profile {path}: {exc}") from None
        return parse_learned_profile(data, str(path))
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProfileError(f"cannot read profile {path}: {exc}") from None
    return parse_profile(text, str(path))
