"""Robot profiles, by name: a TOML file per robot (``<name>.toml``), loaded and validated.

A profile lists the servos of one face: channel, limits in microseconds (min, neutral, max),
whether the servo is reversed, and what drives it, which is exactly one *source*:

* ``points = [...]``: an ``ibug68`` point group (the paper's Table 1) on ``Features.deltas``,
  with ``face_min`` / ``face_max``, the group's movement (inter-ocular units, relative to the
  neutral face) that reaches min_us / max_us when no calibration says otherwise;
* ``feature = "jaw_open"``: a named feature of :mod:`~facesynth.runtime.feature_names` (scaled by
  F: 0 neutral, ±1 the calibrated extremes), mapped ``+1 -> max_us``, ``-1 -> min_us``;
* ``mix = { lip_corner_pull_right = 1.0, lip_corner_depress_right = -1.0 }``: a weighted sum of
  named features (an antagonist pair on one servo), then mapped as ``feature``.

``points`` may also accompany ``feature`` or ``mix`` as a *fallback*: it drives the servo while
the stream has not carried the named feature(s) since the translator started or was reset (an
OpenFace replay has no iris, hence no gaze). Once the feature has been seen, a frame without it
holds the servo.

Per servo, optional: ``gain`` (multiplies the source value, default 1), ``deadband`` (in source
units, default 0), ``max_speed`` (µs/s) and ``max_accel`` (µs/s²) (0 = unlimited), and
``smoothing`` (overrides of the profile's One Euro parameters). Per profile, optional:
``[smoothing]`` (One Euro filter; absent or ``enabled = false`` = no filtering),
``neutral_ramp_s`` (how long a servo without ``max_speed`` takes to return to neutral when the
face is lost) and ``[[safety.exclusive]]`` rules (never two servos of a group beyond
``threshold`` of their travel at once). :data:`FORMAT_REFERENCE` is a commented example of every
field.

Lookup order for a name: a path to an existing file; ``$FACESYNTH_PROFILES``;
``~/.config/facesynth/profiles``; the profiles shipped in this package.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from pathlib import Path
from typing import Any

import msgspec

from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.landmarks import N_IBUG
from facesynth.runtime.named_files import NamedFiles

PACKAGE_DIR = Path(__file__).parent

FORMAT_REFERENCE = """\
name = "robot"                 # required
description = ""
scheme = "ibug68"
mirror = false                 # true: the robot's right follows the performer's left
neutral_seconds = 1.0          # F: seconds of face used as neutral without a calibration
neutral_ramp_s = 0.5           # servos without max_speed: seconds back to neutral (linear)
                               # when the face is lost, and to catch up when it returns; 0 = jump

[smoothing]                    # One Euro filter per source signal; absent = no filtering
enabled = true
min_cutoff = 0.5               # Hz, > 0: cutoff at rest (lower = less jitter, more lag)
beta = 1.0                     # >= 0: cutoff rises by beta x speed (range units per second)
d_cutoff = 1.0                 # Hz, > 0: cutoff of the speed estimate

[[servos]]
name = "jaw"                   # unique
channel = 0                    # unique, >= 0
min_us = 1000                  # min_us <= neutral_us <= max_us, min_us < max_us, min_us >= 0
neutral_us = 1500
max_us = 2000
reversed = false               # swap the directions
points = [56, 57, 58]          # source: an ibug68 group (0..67) on Features.deltas ...
face_min = -0.06               # ... with its movement (IOD) at min_us / max_us: face_min < 0
face_max = 0.3                 #     < face_max (a calibration replaces them)
gain = 1.0                     # finite, non-zero: multiplies the source value
deadband = 0.0                 # >= 0, source units (IOD for points, scaled for named features)
max_speed = 2500               # µs/s, >= 0, 0 = unlimited
max_accel = 30000              # µs/s², >= 0, 0 = unlimited
smoothing = { beta = 0.5 }     # per-servo override of [smoothing] fields (enabled too)

[[servos]]
name = "brow_raise"
channel = 1
min_us = 1000
neutral_us = 1000
max_us = 2000
feature = "brow_raise_inner_right"   # source: a named feature (0 neutral, +-1 calibrated extremes)
max_speed = 3000

[[servos]]
name = "brow_lower"
channel = 2
min_us = 1000
neutral_us = 1000
max_us = 2000
mix = { brow_lower_right = 1.0, brow_raise_outer_right = -0.5 }  # source: a weighted sum
max_speed = 3000

[[safety.exclusive]]           # never two of these servos beyond threshold of their travel
servos = ["brow_raise", "brow_lower"]
threshold = 0.8                # in (0, 1]
"""


class ProfileError(ValueError):
    """A profile that cannot be used; the message names the file and what is wrong.

    ``problems`` lists every problem found (the message joins them with ``"; "``).
    """

    def __init__(self, message: str, problems: list[str] | None = None) -> None:
        super().__init__(message)
        self.problems: list[str] = problems if problems is not None else [message]


class Smoothing(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """One Euro filter parameters (Casiez, Roussel, Vogel, CHI 2012).

    The filter runs on each source signal in *range units*: named features as they are
    (±1 = calibrated extremes), point groups divided by half their face range, so one set of
    parameters fits both.
    """

    enabled: bool = True
    min_cutoff: float = 1.0
    beta: float = 0.0
    d_cutoff: float = 1.0


class SmoothingOverride(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Per-servo changes to the profile's :class:`Smoothing` (unset fields keep the profile's)."""

    enabled: bool | None = None
    min_cutoff: float | None = None
    beta: float | None = None
    d_cutoff: float | None = None


class ExclusiveRule(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """At most one of ``servos`` may be beyond ``threshold`` of its travel at a time."""

    servos: list[str]
    threshold: float = 0.8


class Safety(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Safety rules applied to the translator's output."""

    exclusive: list[ExclusiveRule] = []


class ServoSpec(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """One servo: where it is wired, how far and fast it may move, what drives it."""

    name: str
    channel: int
    min_us: float
    neutral_us: float
    max_us: float
    reversed: bool = False
    points: list[int] = []
    face_min: float | None = None
    face_max: float | None = None
    feature: str | None = None
    mix: dict[str, float] | None = None
    gain: float = 1.0
    deadband: float = 0.0
    max_speed: float = 0.0
    max_accel: float = 0.0
    smoothing: SmoothingOverride | None = None
    description: str = ""

    def clamp(self, position: float) -> float:
        """``position`` limited to this servo's [min_us, max_us]: the last word on safety."""
        return min(max(position, self.min_us), self.max_us)

    def weights(self) -> dict[str, float] | None:
        """The named features driving this servo and their weights (None: a points servo)."""
        if self.feature is not None:
            return {self.feature: 1.0}
        if self.mix is not None:
            return dict(self.mix)
        return None


class Profile(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """A robot or virtual face: its servos and how the performer's face maps onto them."""

    name: str
    description: str = ""
    scheme: str = "ibug68"
    mirror: bool = False
    neutral_seconds: float = 1.0
    neutral_ramp_s: float = 0.5
    smoothing: Smoothing | None = None
    safety: Safety = msgspec.field(default_factory=Safety)
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

    def smoothing_for(self, spec: ServoSpec) -> Smoothing | None:
        """The One Euro parameters for ``spec``'s source, or None when it is not filtered."""
        base = self.smoothing
        if spec.smoothing is None:
            return base if base is not None and base.enabled else None
        merged = msgspec.structs.replace(base) if base is not None else Smoothing()
        for field in ("enabled", "min_cutoff", "beta", "d_cutoff"):
            value = getattr(spec.smoothing, field)
            if value is not None:
                setattr(merged, field, value)
        return merged if merged.enabled else None


def describe_source(spec: ServoSpec) -> str:
    """One line saying what drives ``spec`` (for ``facesynth profile show``)."""
    parts = []
    if spec.feature is not None:
        parts.append(f"feature {spec.feature}")
    if spec.mix is not None:
        parts.append("mix " + ", ".join(f"{w:+g} {name}" for name, w in spec.mix.items()))
    if spec.points:
        parts.append(("fallback points " if parts else "points ") + str(spec.points))
    defaults = {"gain": 1.0, "deadband": 0.0, "max_speed": 0.0, "max_accel": 0.0}
    for field, default in defaults.items():
        value = getattr(spec, field)
        if value != default:
            parts.append(f"{field} {value:g}")
    return "; ".join(parts) or "no source"


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


def _finite(*values: float | None) -> bool:
    return all(v is None or math.isfinite(v) for v in values)


def _unknown_feature(name: str) -> str:
    close = difflib.get_close_matches(name, NAMES, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else " (see facesynth.runtime.feature_names)"
    return f"unknown feature {name!r}{hint}"


def _smoothing_problems(where: str, params: Smoothing | SmoothingOverride) -> list[str]:
    problems = []
    for field in ("min_cutoff", "d_cutoff"):
        value = getattr(params, field)
        if value is not None and not (math.isfinite(value) and value > 0):
            problems.append(f"{where}.{field} must be a positive number of Hz (got {value:g})")
    if params.beta is not None and not (math.isfinite(params.beta) and params.beta >= 0):
        problems.append(f"{where}.beta must be a number >= 0 (got {params.beta:g})")
    return problems


def _source_problems(where: str, spec: ServoSpec) -> list[str]:
    problems: list[str] = []
    named = [field for field in ("feature", "mix") if getattr(spec, field) is not None]
    if not spec.points and not named:
        problems.append(f"{where}: no points, feature or mix (give exactly one source)")
    if len(named) > 1:
        problems.append(
            f"{where}: several sources (feature and mix); give exactly one "
            "(points may accompany either as a fallback)"
        )
    if spec.feature is not None and spec.feature not in NAMES:
        problems.append(f"{where}: {_unknown_feature(spec.feature)}")
    if spec.mix is not None:
        if not spec.mix:
            problems.append(f"{where}: mix is empty (give named features and their weights)")
        for name, weight in spec.mix.items():
            if name not in NAMES:
                problems.append(f"{where}: mix: {_unknown_feature(name)}")
            if not (math.isfinite(weight) and weight != 0):
                problems.append(
                    f"{where}: mix weight of {name!r} must be a finite non-zero number "
                    f"(got {weight:g})"
                )
    if not spec.points:
        if spec.face_min is not None or spec.face_max is not None:
            problems.append(f"{where}: face_min/face_max apply to points only (no points given)")
        return problems
    bad = [p for p in spec.points if not 0 <= p < N_IBUG]
    if bad:
        problems.append(f"{where}: points {bad} are outside 0..{N_IBUG - 1}")
    if spec.face_min is None or spec.face_max is None:
        missing = [f for f in ("face_min", "face_max") if getattr(spec, f) is None]
        problems.append(f"{where}: points need face_min and face_max (missing {missing})")
    elif not _finite(spec.face_min, spec.face_max):
        problems.append(f"{where}: limits and ranges must be finite numbers")
    elif not spec.face_min < 0 < spec.face_max:
        problems.append(
            f"{where}: needs face_min < 0 < face_max (got {spec.face_min:g}, {spec.face_max:g})"
        )
    return problems


def _motion_problems(where: str, spec: ServoSpec) -> list[str]:
    problems = []
    if not (math.isfinite(spec.gain) and spec.gain != 0):
        problems.append(f"{where}: gain must be a finite non-zero number (got {spec.gain:g})")
    for field, unit in (
        ("deadband", "source units"),
        ("max_speed", "µs/s; 0 = unlimited"),
        ("max_accel", "µs/s²; 0 = unlimited"),
    ):
        value = getattr(spec, field)
        if not (math.isfinite(value) and value >= 0):
            problems.append(
                f"{where}: {field} must be a finite number >= 0 ({unit}; got {value:g})"
            )
    if spec.smoothing is not None:
        problems.extend(_smoothing_problems(f"{where}: smoothing", spec.smoothing))
    return problems


def _safety_problems(profile: Profile, names: set[str]) -> list[str]:
    problems = []
    for index, rule in enumerate(profile.safety.exclusive):
        where = f"safety.exclusive[{index}]"
        unknown = [name for name in rule.servos if name not in names]
        if unknown:
            problems.append(f"{where}: unknown servos {unknown}")
        if len(set(rule.servos)) < 2 or len(set(rule.servos)) != len(rule.servos):
            problems.append(f"{where}: needs two or more different servos (got {rule.servos})")
        if not (math.isfinite(rule.threshold) and 0 < rule.threshold <= 1):
            problems.append(f"{where}: threshold {rule.threshold:g} is outside (0, 1]")
    return problems


def validate_profile(profile: Profile) -> list[str]:
    """Every problem of a parsed profile, as precise messages (empty when valid)."""
    problems: list[str] = []
    if not profile.name:
        problems.append("name is empty")
    if profile.scheme != "ibug68":
        problems.append(f"scheme {profile.scheme!r} is not supported (use 'ibug68')")
    if not (math.isfinite(profile.neutral_seconds) and profile.neutral_seconds > 0):
        problems.append("neutral_seconds must be a positive number")
    if not (math.isfinite(profile.neutral_ramp_s) and profile.neutral_ramp_s >= 0):
        problems.append(
            f"neutral_ramp_s must be a number of seconds >= 0 (got {profile.neutral_ramp_s:g})"
        )
    if profile.smoothing is not None:
        problems.extend(_smoothing_problems("smoothing", profile.smoothing))
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
        problems.extend(_source_problems(where, spec))
        problems.extend(_motion_problems(where, spec))
        if not _finite(spec.min_us, spec.neutral_us, spec.max_us):
            problems.append(f"{where}: limits and ranges must be finite numbers")
            continue
        if not spec.min_us <= spec.neutral_us <= spec.max_us or spec.min_us >= spec.max_us:
            problems.append(
                f"{where}: needs min_us <= neutral_us <= max_us and min_us < max_us "
                f"(got {spec.min_us:g}, {spec.neutral_us:g}, {spec.max_us:g})"
            )
        if spec.min_us < 0:
            problems.append(f"{where}: min_us {spec.min_us:g} is negative")
    problems.extend(_safety_problems(profile, names))
    return problems
