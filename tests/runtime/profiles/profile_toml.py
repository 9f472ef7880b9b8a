"""A small TOML writer for test profiles: servos as dicts, a profile as text."""

from __future__ import annotations

import math
from typing import Any


def toml_value(value: Any) -> str:
    """``value`` as a TOML literal."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, float) and math.isnan(value):
        return "nan"
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return repr(value)


def feature_servo(**kw: Any) -> dict[str, Any]:
    """A servo driven by the named feature ``jaw_open`` (None values are left out)."""
    servo: dict[str, Any] = dict(
        name="jaw", channel=0, min_us=1000, neutral_us=1500, max_us=2000, feature="jaw_open"
    )
    servo.update(kw)
    return {k: v for k, v in servo.items() if v is not None}


def points_servo(**kw: Any) -> dict[str, Any]:
    """A servo driven by the jaw's ibug68 point group, the paper's kind of servo."""
    servo: dict[str, Any] = dict(
        name="jaw",
        channel=0,
        points=[56, 57, 58],
        min_us=1000,
        neutral_us=1500,
        max_us=2000,
        face_min=-0.1,
        face_max=0.2,
    )
    servo.update(kw)
    return servo


def profile_toml(
    servos: list[dict[str, Any]] | None = None,
    *,
    smoothing: dict[str, Any] | None = None,
    exclusive: list[dict[str, Any]] | None = None,
    **top: Any,
) -> str:
    """Profile TOML with ``servos`` (default: one :func:`feature_servo`)."""
    head: dict[str, Any] = {"name": "test"}
    head.update(top)
    lines = [f"{key} = {toml_value(value)}" for key, value in head.items()]
    if smoothing is not None:
        lines.append("[smoothing]")
        lines.extend(f"{key} = {toml_value(value)}" for key, value in smoothing.items())
    for servo in [feature_servo()] if servos is None else servos:
        lines.append("[[servos]]")
        lines.extend(f"{key} = {toml_value(value)}" for key, value in servo.items())
    for rule in exclusive or []:
        lines.append("[[safety.exclusive]]")
        lines.extend(f"{key} = {toml_value(value)}" for key, value in rule.items())
    return "\n".join(lines) + "\n"


def points_toml(servos: list[dict[str, Any]] | None = None, **top: Any) -> str:
    """Profile TOML with ``servos`` (default: one :func:`points_servo`)."""
    return profile_toml([points_servo()] if servos is None else servos, **top)


PAIR = [
    feature_servo(name="up", channel=0),
    feature_servo(name="down", channel=1, feature="brow_lower_right"),
]
POINTS = dict(feature=None, points=[56, 57, 58], face_min=-0.1, face_max=0.2)
