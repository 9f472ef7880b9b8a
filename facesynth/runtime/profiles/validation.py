"""Every problem of a parsed profile, as precise one-line messages."""

from __future__ import annotations

import difflib
import math

from facesynth.runtime.feature_names import BLENDSHAPE_NAMES, NAMES
from facesynth.runtime.landmarks import N_IBUG

from .learned import learned_problems
from .model import Profile, ServoSpec, Smoothing, SmoothingOverride

#: ``max_command_age_s`` bounds: shorter than a frame's way through a loaded chain drops live
#: commands; longer than a few seconds executes what a healed link held back.
MIN_COMMAND_AGE_S = 0.02
MAX_COMMAND_AGE_S = 5.0


def _finite(*values: float | None) -> bool:
    return all(v is None or math.isfinite(v) for v in values)


def _unknown_feature(name: str) -> str:
    close = difflib.get_close_matches(name, NAMES, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else " (see facesynth.runtime.feature_names)"
    return f"unknown feature {name!r}{hint}"


def _unknown_blendshape(name: str) -> str:
    if name in NAMES:
        return f"{name!r} is a feature, not a blendshape (use feature = {name!r})"
    close = difflib.get_close_matches(name, sorted(BLENDSHAPE_NAMES), n=1)
    hint = (
        f" (did you mean {close[0]!r}?)"
        if close
        else " (one of the 51 ARKit names, e.g. 'mouthSmileLeft': facesynth.runtime.blendshapes)"
    )
    return f"unknown blendshape {name!r}{hint}"


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
    named = [
        field for field in ("feature", "blendshape", "mix") if getattr(spec, field) is not None
    ]
    if len(named) > 1:
        problems.append(
            f"{where}: several sources ({' and '.join(named)}); give exactly one "
            "(points may accompany any of them as a fallback)"
        )
    if spec.feature is not None and spec.feature not in NAMES:
        problems.append(f"{where}: {_unknown_feature(spec.feature)}")
    if spec.blendshape is not None and spec.blendshape not in BLENDSHAPE_NAMES:
        problems.append(f"{where}: {_unknown_blendshape(spec.blendshape)}")
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


def _angle_problems(where: str, spec: ServoSpec) -> list[str]:
    angle = spec.angle
    if not _finite(angle.min_us, angle.max_us, angle.min_deg, angle.max_deg):
        return [f"{where}: angle: min_us, max_us, min_deg and max_deg must be finite numbers"]
    if angle.min_us >= angle.max_us:
        return [f"{where}: angle: needs min_us < max_us (got {angle.min_us:g}, {angle.max_us:g})"]
    if angle.min_deg == angle.max_deg:
        return [f"{where}: angle: min_deg and max_deg are both {angle.min_deg:g}"]
    return []


def _bus_problems(where: str, spec: ServoSpec) -> list[str]:
    problems = []
    if spec.bus_id is not None and not 0 <= spec.bus_id <= 252:
        problems.append(f"{where}: bus_id {spec.bus_id} is outside 0..252")
    if (spec.native_min is None) != (spec.native_max is None):
        problems.append(f"{where}: give native_min and native_max together")
    elif (
        spec.native_min is not None
        and spec.native_max is not None
        and (spec.native_min == spec.native_max or min(spec.native_min, spec.native_max) < 0)
    ):
        problems.append(
            f"{where}: native_min and native_max must differ and be >= 0 "
            f"(got {spec.native_min}, {spec.native_max})"
        )
    return problems


def _bus_id(spec: ServoSpec) -> int:
    return spec.bus_id if spec.bus_id is not None else spec.channel + 1


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
    if not (
        math.isfinite(profile.max_command_age_s)
        and MIN_COMMAND_AGE_S <= profile.max_command_age_s <= MAX_COMMAND_AGE_S
    ):
        problems.append(
            f"max_command_age_s must be a number of seconds from {MIN_COMMAND_AGE_S:g} to "
            f"{MAX_COMMAND_AGE_S:g} (got {profile.max_command_age_s:g})"
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
        problems.extend(_angle_problems(where, spec))
        problems.extend(_bus_problems(where, spec))
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
    seen: dict[int, str] = {}
    for spec in profile.servos:
        other = seen.setdefault(_bus_id(spec), spec.name)
        if other != spec.name:
            problems.append(
                f"servo {spec.name!r}: bus id {_bus_id(spec)} is taken by servo {other!r}"
            )
    if profile.bus is not None:
        if profile.bus.baud is not None and profile.bus.baud <= 0:
            problems.append(f"bus.baud must be a positive baud rate (got {profile.bus.baud})")
        if profile.bus.protocol not in (None, 1, 2):
            problems.append(f"bus.protocol must be 1 or 2 (got {profile.bus.protocol})")
    if profile.learned is not None:
        servos = [spec.name for spec in profile.servos]
        problems.extend(f"learned: {p}" for p in learned_problems(profile.learned, servos))
    return problems
