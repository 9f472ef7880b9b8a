"""Bring-up sweeps: one servo from neutral to each limit and back, slowly (pure: time as steps).

``facesynth control test`` sends one step every ``1 / rate_hz`` seconds while the other servos
hold neutral: neutral → min, hold, → neutral, → max, hold, → neutral. No step moves more than
``speed_us_s / rate_hz``, and every position lies within the servo's limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from facesynth.runtime.profiles import ServoSpec


@dataclass(frozen=True)
class SweepStep:
    """One step: where the servo is sent, and which leg of the sweep it belongs to."""

    position: float
    leg: str  # "min", "hold min", "neutral", "max", "hold max"
    arrived: bool  # the last step of its leg


def sweep(spec: ServoSpec, speed_us_s: float, rate_hz: float, hold_s: float) -> list[SweepStep]:
    """The steps of one servo's sweep; ``ValueError`` for a speed or rate that is not positive."""
    if not (speed_us_s > 0 and math.isfinite(speed_us_s)):
        raise ValueError(f"the sweep speed must be a positive number of us/s (got {speed_us_s})")
    if not rate_hz > 0 or hold_s < 0:
        raise ValueError("the sweep needs a positive rate and a hold time >= 0")
    per_step = speed_us_s / rate_hz
    steps: list[SweepStep] = []
    here = spec.neutral_us
    for target, leg in (
        (spec.min_us, "min"),
        (spec.neutral_us, "neutral"),
        (spec.max_us, "max"),
        (spec.neutral_us, "neutral"),
    ):
        count = max(1, math.ceil(abs(target - here) / per_step - 1e-9))
        for i in range(1, count + 1):
            position = spec.clamp(here + (target - here) * i / count)
            steps.append(SweepStep(position, leg, i == count))
        here = target
        if leg != "neutral":
            hold = round(hold_s * rate_hz)
            steps += [SweepStep(target, f"hold {leg}", i == hold) for i in range(1, hold + 1)]
    return steps
