"""Translator T's mapping steps, pure functions: a source value to a servo position (the
paper's piecewise-linear group mapping, the scaled mapping of named features), the dead-band,
and the mirror image's feature names (:mod:`facesynth.services.translator.core` uses them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from facesynth.runtime.profiles import ServoSpec

#: Named features whose sign flips in a mirror image (x directions and in-plane turns).
MIRROR_NEGATED = frozenset({"gaze_right_x", "gaze_left_x", "head_yaw", "head_roll"})


def interpolate(movement: float, face_min: float, face_max: float, spec: ServoSpec) -> float:
    """Servo position for a group movement: piecewise linear through neutral, clamped."""
    if spec.reversed:
        movement = -movement
        face_min, face_max = -face_max, -face_min
    if movement >= 0:
        fraction = min(movement / face_max, 1.0)
        position = spec.neutral_us + fraction * (spec.max_us - spec.neutral_us)
    else:
        fraction = min(movement / face_min, 1.0)
        position = spec.neutral_us - fraction * (spec.neutral_us - spec.min_us)
    return spec.clamp(position)


def scaled_position(value: float, spec: ServoSpec) -> float:
    """Servo position for a scaled value (0 neutral, +1 max_us, -1 min_us; reversed swaps)."""
    if spec.reversed:
        value = -value
    if value >= 0:
        position = spec.neutral_us + value * (spec.max_us - spec.neutral_us)
    else:
        position = spec.neutral_us + value * (spec.neutral_us - spec.min_us)
    return spec.clamp(position)


def deadband(value: float, width: float) -> float:
    """0 within ``±width``, else ``value`` moved toward 0 by ``width`` (continuous)."""
    if abs(value) <= width:
        return 0.0
    return value - math.copysign(width, value)


def mirror_name(name: str) -> str:
    """The name of a feature's mirror-image counterpart: ``_right``/``_left`` swapped, and the
    blendshapes' ``Left``/``Right`` endings (``mouthSmileLeft``, ``jawLeft``) swapped."""
    if name.endswith("_right") or "_right_" in name:
        return name.replace("_right", "_left", 1)
    if name.endswith("_left") or "_left_" in name:
        return name.replace("_left", "_right", 1)
    if name.endswith("Left"):
        return name[: -len("Left")] + "Right"
    if name.endswith("Right"):
        return name[: -len("Right")] + "Left"
    return name


def mirror_named(named: Mapping[str, float]) -> dict[str, float]:
    """Named features of the mirror image: right and left swapped, x directions negated."""
    out = {}
    for name, value in named.items():
        name = mirror_name(name)
        out[name] = -value if name in MIRROR_NEGATED else value
    return out
