"""Performer calibrations, by name: a JSON file per performer (``<name>.json``).

A calibration holds the performer's neutral face (the 68 nose-tip distances, in inter-ocular
units) and, per point, the smallest and largest movement from that neutral seen during extreme
expressions (``delta_min`` <= 0 <= ``delta_max``). F uses the neutral; T averages the per-point
ranges over each servo's point group. Files are written atomically.

Lookup order for a name: a path to an existing file; ``$FACESYNTH_CALIBRATIONS``;
``~/.config/facesynth/calibrations``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Literal

import msgspec

from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.landmarks import N_IBUG
from facesynth.runtime.named_files import NamedFiles
from facesynth.runtime.oneline import one_line

#: Largest magnitude of a calibrated or learned value (inter-ocular units, degrees): a face's
#: are near 1, and anything beyond this is a corrupt file (F's features would then be refused
#: by every receiver).
MAX_VALUE = 1e3


def finite_within(values: Iterable[float], limit: float = MAX_VALUE) -> bool:
    """Whether every value is a finite number within ±``limit``."""
    return all(math.isfinite(v) and abs(v) <= limit for v in values)


class CalibrationError(ValueError):
    """A calibration that cannot be used; the message names the file and what is wrong."""


class Calibration(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """One performer's neutral face and movement ranges."""

    format: Literal["facesynth.runtime.calibration"] = "facesynth.runtime.calibration"
    version: int = 1
    name: str
    scheme: str = "ibug68"
    feature: Literal["nose_distance"] = "nose_distance"
    neutral: list[float]
    delta_min: list[float]
    delta_max: list[float]
    created: str = ""
    # Named features (runtime.feature_names): the neutral's raw values and, relative to it,
    # the calibrated extremes; features missing here keep their defaults.
    named_neutral: dict[str, float] = {}
    named_min: dict[str, float] = {}
    named_max: dict[str, float] = {}
    # The neutral face mesh (468 x 3, flattened), for head pose relative to neutral.
    neutral_mesh: list[float] = []


CALIBRATIONS = NamedFiles("calibration", ".json", "FACESYNTH_CALIBRATIONS")


def resolve_calibration(name_or_path: str) -> Path:
    """The file a calibration name or path refers to, or raise :class:`CalibrationError`."""
    try:
        return CALIBRATIONS.resolve(name_or_path)
    except LookupError as exc:
        raise CalibrationError(str(exc)) from None


def validate_calibration(calibration: Calibration) -> list[str]:
    """Every problem of a parsed calibration (empty when valid)."""
    problems = []
    if calibration.version != 1:
        problems.append(f"version {calibration.version} is not supported (this facesynth reads 1)")
    if calibration.scheme != "ibug68":
        problems.append(f"scheme {calibration.scheme!r} is not supported")
    for field in ("neutral", "delta_min", "delta_max"):
        values = getattr(calibration, field)
        if len(values) != N_IBUG:
            problems.append(f"{field} has {len(values)} values, needs {N_IBUG}")
        elif not finite_within(values):
            problems.append(
                f"{field} has a value that is not a finite number within ±{MAX_VALUE:g}"
            )
    for field in ("named_neutral", "named_min", "named_max"):
        values = getattr(calibration, field)
        unknown = sorted(set(values) - set(NAMES))
        if unknown:
            problems.append(f"{field} names unknown features {unknown}")
        if not finite_within(values.values()):
            problems.append(
                f"{field} has a value that is not a finite number within ±{MAX_VALUE:g}"
            )
    if calibration.neutral_mesh and (
        len(calibration.neutral_mesh) != 468 * 3
        or not all(math.isfinite(v) for v in calibration.neutral_mesh)
    ):
        problems.append("neutral_mesh needs 1404 finite values (468 x 3) or none")
    if problems:
        return problems
    wrong_named = sorted(
        name
        for name in set(calibration.named_min) | set(calibration.named_max)
        if not calibration.named_min.get(name, -1.0) < 0 < calibration.named_max.get(name, 1.0)
    )
    if wrong_named:
        problems.append(f"named features {wrong_named} need named_min < 0 < named_max")
    if any(v < 0 for v in calibration.neutral):
        problems.append("neutral distances cannot be negative")
    wrong = [
        i
        for i, (lo, hi) in enumerate(zip(calibration.delta_min, calibration.delta_max, strict=True))
        if not lo <= 0 <= hi
    ]
    if wrong:
        problems.append(f"points {wrong} need delta_min <= 0 <= delta_max")
    return problems


def parse_calibration(data: bytes | str, source: str = "<calibration>") -> Calibration:
    """Parse and validate calibration JSON."""
    try:
        calibration = msgspec.json.decode(data, type=Calibration)
    except (msgspec.DecodeError, msgspec.ValidationError, UnicodeDecodeError) as exc:
        raise CalibrationError(f"{source}: {one_line(str(exc))}") from None
    problems = validate_calibration(calibration)
    if problems:
        raise CalibrationError(f"{source}: " + "; ".join(problems))
    return calibration


def load_calibration(name_or_path: str) -> Calibration:
    """Load a calibration by name or path, validated."""
    path = resolve_calibration(name_or_path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise CalibrationError(f"cannot read calibration {path}: {exc}") from None
    return parse_calibration(data, str(path))


def save_calibration(calibration: Calibration, path: str | os.PathLike[str]) -> Path:
    """Validate and write a calibration atomically."""
    problems = validate_calibration(calibration)
    if problems:
        raise CalibrationError("; ".join(problems))
    return write_atomic(path, msgspec.json.format(msgspec.json.encode(calibration)))
