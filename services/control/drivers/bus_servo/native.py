"""A profile's servos in a smart servo's native position units.

The chain works in microseconds; a bus servo takes positions in its own units (a Dynamixel X
or a Feetech STS: 4096 per turn; an AX-12A: 1024 over 300°). Each servo converts linearly:

- with ``native_min`` and ``native_max`` in the profile: ``min_us`` is ``native_min`` and
  ``max_us`` is ``native_max``;
- otherwise through the servo's ``angle`` map (default 500-2500 µs over 0-180°, so 0.09° per
  µs), 1500 µs being the model's centre (2048 of 4096, 512 of 1024).

Limits are rounded inward, every position is rounded and clamped again right before it is
encoded, and a servo whose limits land outside what its model can reach is refused.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.model import ServoSpec
from facesynth.services.control.drivers.base import DriverConfigError, DriverError


@dataclass(frozen=True)
class Model:
    """A servo model a driver knows: its number and its position range."""

    name: str
    number: int
    positions: int  # native positions 0..positions-1
    degrees: float  # the angle they span
    protocol: int = 2  # Dynamixel 1 or 2; Feetech 0 (STS, little-endian) or 1 (SCS, big)

    @property
    def centre(self) -> int:
        return self.positions // 2

    @property
    def units_per_degree(self) -> float:
        return self.positions / self.degrees


def bus_id(spec: ServoSpec) -> int:
    """The servo's id on the bus: ``bus_id``, else channel + 1."""
    return spec.bus_id if spec.bus_id is not None else spec.channel + 1


@dataclass(frozen=True)
class NativeServo:
    """One servo's conversion: µs <-> native units, limits in native units (inward)."""

    name: str
    bus_id: int
    model: Model
    scale: float  # native units per µs (negative: reversed wiring through native_min/max)
    offset: float  # native units at 0 µs
    low: int
    neutral: int
    high: int

    def native(self, us: float) -> int:
        """``us`` in native units, rounded and clamped to the servo's limits."""
        return min(max(round(self.offset + self.scale * us), self.low), self.high)

    def us(self, native: float) -> float:
        """Native units back to µs."""
        return (native - self.offset) / self.scale

    def units_per_s(self, us_per_s: float) -> float:
        """A speed (or acceleration, per second squared) in native units."""
        return abs(self.scale) * us_per_s


def native_servo(spec: ServoSpec, model: Model) -> NativeServo:
    """``spec`` on ``model``; :class:`DriverConfigError` if its limits fall outside the model."""
    if spec.native_min is not None and spec.native_max is not None:
        scale = (spec.native_max - spec.native_min) / (spec.max_us - spec.min_us)
        offset = spec.native_min - scale * spec.min_us
    else:
        angle = spec.angle
        deg_per_us = (angle.max_deg - angle.min_deg) / (angle.max_us - angle.min_us)
        scale = deg_per_us * model.units_per_degree
        offset = model.centre - scale * 1500.0
    ends = sorted((offset + scale * spec.min_us, offset + scale * spec.max_us))
    low, high = math.ceil(ends[0] - 1e-6), math.floor(ends[1] + 1e-6)
    if low < 0 or high > model.positions - 1 or low > high:
        raise DriverConfigError(
            f"servo {spec.name!r}: limits {spec.min_us:g}..{spec.max_us:g} us are native "
            f"{ends[0]:.0f}..{ends[1]:.0f}, outside the {model.name}'s 0..{model.positions - 1}"
        )
    neutral = min(max(round(offset + scale * spec.neutral_us), low), high)
    return NativeServo(spec.name, bus_id(spec), model, scale, offset, low, neutral, high)


class NativePose:
    """The profile's servos by name and by bus id; positions in µs checked and converted."""

    def __init__(self, profile: Profile) -> None:
        self.profile_name = profile.name
        self.specs = {spec.name: spec for spec in profile.servos}
        self.ids = {spec.name: bus_id(spec) for spec in profile.servos}
        self.servos: dict[int, NativeServo] = {}

    def bind(self, models: dict[int, Model], *, strict: bool = True) -> dict[int, str]:
        """Convert with the models found on the bus (by id). ``strict``: every servo must have
        its model and fit it (else :class:`DriverConfigError`); otherwise those that cannot
        are left out and their problems returned by id."""
        self.servos = {}
        problems: dict[int, str] = {}
        for name, spec in self.specs.items():
            servo_id = self.ids[name]
            if servo_id not in models and not strict:
                continue
            try:
                self.servos[servo_id] = native_servo(spec, models[servo_id])
            except DriverConfigError as exc:
                if strict:
                    raise
                problems[servo_id] = str(exc)
        return problems

    def checked_us(self, positions: Mapping[str, float]) -> dict[str, float]:
        """Positions by name, refused (:class:`DriverError`) for unknown servos and
        non-finite values, clamped to the profile's limits."""
        out: dict[str, float] = {}
        for name, us in positions.items():
            spec = self.specs.get(name)
            if spec is None:
                raise DriverError(f"servo {name!r} is not in profile {self.profile_name!r}")
            if not math.isfinite(us):
                raise DriverError(f"position of {name!r} is {us}")
            out[name] = spec.clamp(us)
        return out
