"""Head files: a simulated head's actuators, their messy responses and what they move (TOML).

A head is a list of actuators, one per servo channel::

    name = "simhead16"
    description = "…"

    [[actuators]]
    name = "right_eyebrow"      # as the hardware profile names the servo (for people only)
    channel = 0
    min_us = 1000               # the pulse range the actuator physically responds over:
    max_us = 2000               #   pulses beyond it are clamped to it
    rest_us = 1530              # the pulse at which the skin is at rest (an offset)
    dead_band_us = 10           # no motion within this distance of rest_us
    curve = "power"             # linear | power | smoothstep: response over each side's travel
    exponent = 1.4              # power curve: (travel share) ** exponent
    gain_up = 1.0               # activation at max_us (asymmetry: another gain below rest)
    gain_down = 0.7             # activation magnitude at min_us
    reversed = false            # a larger pulse moves the effects the other way
    slew_us_per_s = 2500        # the fastest the horn turns
    lag_s = 0.05                # then the skin follows with this first-order time constant
    effects = { brow_right = 1.0 }          # activation per unit of the actuator's output
    coupling = { brow_inner = 0.15 }        # other regions, scaled by output * |output|

An actuator with no effects is a dead channel. Effect names are :data:`.effects.EFFECTS`.
Every field is checked (types, ranges, names); a bad file is one :class:`HeadError` line.
A learner never reads this file: it only sees the serial port and the camera.
"""

from __future__ import annotations

import tomllib
from typing import Annotated, Literal

import msgspec

from facesynth.runtime.oneline import one_line

from .effects import EFFECTS

__all__ = ["Actuator", "HeadConfig", "HeadError", "parse_head"]


class HeadError(ValueError):
    """A head file or name that cannot be used."""


Pulse = Annotated[float, msgspec.Meta(ge=500, le=2500)]


class Actuator(msgspec.Struct, kw_only=True, forbid_unknown_fields=True, frozen=True):
    """One actuator: its channel, its response and the effects it drives (see the module)."""

    name: str
    channel: Annotated[int, msgspec.Meta(ge=0, le=23)]
    min_us: Pulse = 1000.0
    max_us: Pulse = 2000.0
    rest_us: Pulse = 1500.0
    dead_band_us: Annotated[float, msgspec.Meta(ge=0)] = 0.0
    curve: Literal["linear", "power", "smoothstep"] = "linear"
    exponent: Annotated[float, msgspec.Meta(gt=0, le=5)] = 1.0
    gain_up: Annotated[float, msgspec.Meta(ge=0, le=3)] = 1.0
    gain_down: Annotated[float, msgspec.Meta(ge=0, le=3)] = 1.0
    reversed: bool = False
    slew_us_per_s: Annotated[float, msgspec.Meta(gt=0)] = 4000.0
    lag_s: Annotated[float, msgspec.Meta(ge=0, le=2)] = 0.0
    effects: dict[str, float] = {}
    coupling: dict[str, float] = {}


class HeadConfig(msgspec.Struct, kw_only=True, forbid_unknown_fields=True, frozen=True):
    """A simulated head: its name and its actuators (one per channel)."""

    name: str
    description: str = ""
    actuators: list[Actuator]

    def by_channel(self) -> dict[int, Actuator]:
        """The actuators keyed by channel."""
        return {a.channel: a for a in self.actuators}


def _check(config: HeadConfig, where: str) -> HeadConfig:
    if not config.actuators:
        raise HeadError(f"{where}: a head needs at least one actuator")
    seen: dict[int, str] = {}
    for a in config.actuators:
        label = f"{where}: actuator {a.name!r}"
        if a.channel in seen:
            raise HeadError(f"{label}: channel {a.channel} is also {seen[a.channel]!r}")
        seen[a.channel] = a.name
        if not a.min_us < a.max_us:
            raise HeadError(f"{label}: min_us {a.min_us:g} must be below max_us {a.max_us:g}")
        if not a.min_us < a.rest_us < a.max_us:
            raise HeadError(
                f"{label}: rest_us {a.rest_us:g} must be within ({a.min_us:g}, {a.max_us:g})"
            )
        travel = min(a.max_us - a.rest_us, a.rest_us - a.min_us)
        if a.dead_band_us >= travel:
            raise HeadError(f"{label}: dead_band_us {a.dead_band_us:g} leaves no travel")
        for table in ("effects", "coupling"):
            for effect, amount in getattr(a, table).items():
                if effect not in EFFECTS:
                    raise HeadError(
                        f"{label}: unknown effect {effect!r} in {table} "
                        f"(known: {', '.join(EFFECTS)})"
                    )
                if not -3.0 <= amount <= 3.0:
                    raise HeadError(f"{label}: {table}.{effect} = {amount:g} is beyond +-3")
    return config


def parse_head(text: str | bytes, where: str = "head") -> HeadConfig:
    """A head from TOML text (``where`` names it in errors)."""
    try:
        raw = tomllib.loads(text.decode("utf-8") if isinstance(text, bytes) else text)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise HeadError(f"{where}: not valid TOML ({one_line(str(exc))})") from None
    try:
        config = msgspec.convert(raw, HeadConfig)
    except msgspec.ValidationError as exc:  # quotes a key as it is: it may hold a newline
        raise HeadError(f"{where}: {one_line(str(exc))}") from None
    return _check(config, where)
