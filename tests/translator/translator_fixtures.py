"""Servos, profiles and feature frames for the translator's tests."""

from __future__ import annotations

from typing import Any

import numpy as np

from facesynth.runtime.profiles import Profile, ServoSpec
from facesynth.schemas.messages import Features
from facesynth.services.translator.core import Translator

FPS = 30.0
DT = 1.0 / FPS
TOL = 1e-3  # µs: t_media_ns is whole nanoseconds, so frames are not all exactly 1/30 s


def feature_servo(name: str = "s", channel: int = 0, **kw: Any) -> ServoSpec:
    """A servo driven by ``jaw_open`` unless a source is given."""
    fields: dict[str, Any] = dict(
        name=name, channel=channel, min_us=1000.0, neutral_us=1500.0, max_us=2000.0
    )
    if not {"points", "feature", "blendshape", "mix"} & kw.keys():
        fields["feature"] = "jaw_open"
    fields.update(kw)
    return ServoSpec(**fields)


def points_servo(name: str = "p", channel: int = 0, **kw: Any) -> ServoSpec:
    """A servo driven by the jaw's ibug68 point group."""
    return feature_servo(name, channel, points=[56, 57, 58], face_min=-0.1, face_max=0.2, **kw)


def profile_of(*servos: ServoSpec, **kw: Any) -> Profile:
    """A profile named ``t`` of ``servos``."""
    return Profile(name="t", servos=list(servos), **kw)


def features_at(
    index: int,
    named: dict[str, float] | None = None,
    deltas: list[float] | np.ndarray | None = None,
    *,
    face: bool = True,
    ready: bool = True,
    t_ns: int | None = None,
) -> Features:
    """Features of frame ``index`` at 30 fps (``t_ns`` overrides the media time)."""
    return Features(
        seq=index,
        t_capture_ns=7,
        t_media_ns=round(index * 1e9 / FPS) if t_ns is None else t_ns,
        face=face,
        neutral_ready=ready,
        deltas=[] if deltas is None else [float(v) for v in deltas],
        named={} if named is None else named,
    )


def jaw_deltas(value: float) -> np.ndarray:
    """68 deltas: the jaw's group moved by ``value``, every other point still."""
    deltas = np.zeros(68)
    deltas[[56, 57, 58]] = value
    return deltas


def positions_of(translator: Translator, frames: list[Features], servo: str = "s") -> list[float]:
    """The positions of one servo over ``frames``."""
    return [translator.step(frame)[servo] for frame in frames]


SMILE = {"lip_corner_pull_right": 1.0, "lip_corner_depress_right": -1.0}
