"""Robot profiles, by name: a TOML file per robot (``<name>.toml``), loaded and validated.

A profile lists the servos of one face: channel, limits in microseconds (min, neutral, max),
whether the servo is reversed, which ``ibug68`` points drive it (the paper's Table 1 groups) and
the default feature range of that group (the movement, in inter-ocular units relative to the
neutral face, that reaches the servo's min and max when no calibration says otherwise).

Lookup order for a name: a path to an existing file; ``$FACESYNTH_PROFILES``;
``~/.config/facesynth/profiles``; the profiles shipped in this package.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import msgspec

from facesynth.landmarks import N_IBUG
from facesynth.named_files import NamedFiles

PACKAGE_DIR = Path(__file__).parent


class ProfileError(ValueError):
    """A profile that cannot be used; the message names the file and what is wrong."""


class ServoSpec(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """One servo: where it is wired, how far it may move, what drives it."""

    name: str
    channel: int
    points: list[int]
    min_us: float
    neutral_us: float
    max_us: float
    reversed: bool = False
    face_min: float
    face_max: float
    description: str = ""


class Profile(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """A robot or virtual face: its servos and how the performer's face maps onto them."""

    name: str
    description: str = ""
    scheme: str = "ibug68"
    mirror: bool = False
    neutral_seconds: float = 1.0
    servos: list[ServoSpec]

    def servo(self, name: str) -> ServoSpec:
        """The servo called ``name`` (KeyError if there is none)."""
        for spec in self.servos:
            if spec.name == name:
                return spec
        raise KeyError(name)

    def neutral_positions(self) -> dict[str, float]:
        """Every servo at its neutral position."""
        return {spec.name: spec.neutral_us for spec in self.servos}


PROFILES = NamedFiles("profile", ".toml", "FACESYNTH_PROFILES", PACKAGE_DIR, list_available=True)


def search_dirs() -> list[Path]:
    """Folders searched for ``<name>.toml``, first match wins."""
    return PROFILES.search_dirs()


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
    """Parse and validate profile TOML text."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{source}: not valid TOML: {exc}") from None
    try:
        profile = msgspec.convert(data, Profile)
    except msgspec.ValidationError as exc:
        raise ProfileError(f"{source}: {exc}") from None
    problems = validate_profile(profile)
    if problems:
        raise ProfileError(f"{source}: " + "; ".join(problems))
    return profile


def load_profile(name_or_path: str) -> Profile:
    """Load a profile by name or path, validated."""
    path = resolve_profile(name_or_path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProfileError(f"cannot read profile {path}: {exc}") from None
    return parse_profile(text, str(path))


def validate_profile(profile: Profile) -> list[str]:
    """Every problem of a parsed profile, as precise messages (empty when valid)."""
    problems: list[str] = []
    if not profile.name:
        problems.append("name is empty")
    if profile.scheme != "ibug68":
        problems.append(f"scheme {profile.scheme!r} is not supported (use 'ibug68')")
    if not (math.isfinite(profile.neutral_seconds) and profile.neutral_seconds > 0):
        problems.append("neutral_seconds must be a positive number")
    if not profile.servos:
        problems.append("no servos")
    names: set[str] = set()
    channels: set[int] = set()
    for spec in profile.servos:
        where = f"servo {spec.name!r}"
        if not spec.name:
            problems.append("a servo has an empty name")
        if spec.name in names:
            problems.append(f"{where} is defined twice")
        names.add(spec.name)
        if spec.channel < 0:
            problems.append(f"{where}: channel {spec.channel} is negative")
        if spec.channel in channels:
            problems.append(f"{where}: channel {spec.channel} is used twice")
        channels.add(spec.channel)
        values = (spec.min_us, spec.neutral_us, spec.max_us, spec.face_min, spec.face_max)
        if not all(math.isfinite(v) for v in values):
            problems.append(f"{where}: limits and ranges must be finite numbers")
            continue
        if not spec.min_us <= spec.neutral_us <= spec.max_us or spec.min_us >= spec.max_us:
            problems.append(
                f"{where}: needs min_us <= neutral_us <= max_us and min_us < max_us "
                f"(got {spec.min_us:g}, {spec.neutral_us:g}, {spec.max_us:g})"
            )
        if spec.min_us < 0:
            problems.append(f"{where}: min_us {spec.min_us:g} is negative")
        if not spec.face_min < 0 < spec.face_max:
            problems.append(
                f"{where}: needs face_min < 0 < face_max (got {spec.face_min:g}, {spec.face_max:g})"
            )
        if not spec.points:
            problems.append(f"{where}: no points")
        bad = [p for p in spec.points if not 0 <= p < N_IBUG]
        if bad:
            problems.append(f"{where}: points {bad} are outside 0..{N_IBUG - 1}")
    return problems
