"""Simulated heads generated from a seed: heads no profile was written for.

``generate_head(seed)`` returns a :class:`~.config.HeadConfig`, the same struct a head file
loads into, drawn deterministically from ``seed`` (Python's :class:`random.Random`, whose
``random()`` stream is the same on every platform and version). Wherever a head is named
(``facesynth simhead``, ``bench robot --head``, ``render --robot-head``), ``seed:N`` or
``generated:N`` names the head of seed ``N`` (:func:`generated_head`).

**Hardware.** A generated head keeps the hardware of the bundled heads: 16 actuators on
channels 0-15, named as ``head16_hardware`` names its servos (:data:`SERVOS`), each responding
within 1000-2000 µs (that profile's limits; a pulse beyond an actuator's own response range is
clamped to it, as on the bundled heads). So the written profiles (paper16, head16, head16_bs),
``facesynth learn --profile head16_hardware`` and ``bench robot --learn-poses`` drive it as
they drive the bundled heads. What changes is everything behind the channels:

* **wiring**: each channel starts with the role paper16 gives it (:data:`ROLES`: the effects
  that servo drives), then 0-3 pairs of channels swap roles (:data:`SWAPS`: left and right
  crossed, an eye's x and y crossed, a cheek's inner and outer, a lip corner and the lower
  lip); each channel is reversed with probability 0.25; with probability 0.25 one channel is
  dead (moves nothing);
* **response**: a curve per actuator (linear, power with an exponent in 0.6-2.2, smoothstep),
  a rest offset within ±60 µs of 1500, a dead band (2-8 µs for the eyes, 5-18 µs elsewhere,
  60-150 µs with probability 0.1), a gain per direction (0.5-1.15), a response range cut to
  as little as 1120-1880 µs, the primary effect's strength at 0.75-1.1 of paper16's;
* **dynamics**: slew 3000-6000 µs/s for the eyes and 1500-3000 elsewhere, a skin lag of
  0.02-0.06 s for the eyes and 0.05-0.15 s elsewhere;
* **coupling**: into the role's neighbouring regions (those the bundled heads couple), each
  kept with probability 0.7 at 0.1-0.5 of the primary motion.

These are the ranges the bundled heads span (simhead16, simhead16_reversed, simhead16_stiff),
which are the ranges of hobby servos under silicone skin. The head's description says how it
is wired (its swaps, reversed and dead channels).
"""

from __future__ import annotations

import random
import re
from dataclasses import dataclass
from typing import Final

import msgspec

from .config import Actuator, HeadConfig, HeadError, _check

__all__ = [
    "PREFIXES",
    "ROLES",
    "SERVOS",
    "SWAPS",
    "generate_head",
    "generated_head",
    "generated_seed",
]

#: How a generated head is named: ``seed:N`` or ``generated:N``.
PREFIXES: Final = ("seed:", "generated:")
#: The largest seed taken (seeds are 0 .. 2**32 - 1).
MAX_SEED: Final = 2**32 - 1


@dataclass(frozen=True)
class Role:
    """What one servo of paper16 drives: its effects (activation per unit of output; the sign
    is paper16's: a cheek is raised by a lower pulse) and the regions its skin drags along
    (coupling sign as the bundled heads have it)."""

    effects: dict[str, float]
    neighbours: dict[str, float]


#: head16_hardware's servos, in channel order (channel = index).
SERVOS: Final = (
    "right_eyebrow",
    "left_eyebrow",
    "middle_eyebrow",
    "right_eye_x",
    "right_eye_y",
    "left_eye_x",
    "left_eye_y",
    "right_inner_cheek",
    "left_inner_cheek",
    "right_outer_cheek",
    "left_outer_cheek",
    "jaw",
    "right_lip_corner",
    "left_lip_corner",
    "right_lower_lip",
    "left_lower_lip",
)

#: Each servo's role as paper16 wires it (the bundled simhead16's effects and couplings).
ROLES: Final[dict[str, Role]] = {
    "right_eyebrow": Role({"brow_right": 1.0}, {"brow_inner": 1.0, "lids_right": 1.0}),
    "left_eyebrow": Role({"brow_left": 0.9}, {"brow_inner": 1.0, "lids_left": 1.0}),
    "middle_eyebrow": Role({"brow_inner": 1.0}, {"brow_right": 1.0, "brow_left": 1.0}),
    "right_eye_x": Role({"gaze_right_x": 1.0}, {"gaze_left_x": 1.0}),
    "right_eye_y": Role({"gaze_right_y": 1.0}, {"lids_right": 1.0}),
    "left_eye_x": Role({"gaze_left_x": 0.95}, {"gaze_right_x": 1.0}),
    "left_eye_y": Role({"gaze_left_y": 1.0}, {"lids_left": 1.0}),
    "right_inner_cheek": Role(
        {"upper_lip_right": -0.8, "cheek_right": -0.4}, {"lip_corner_right": -1.0}
    ),
    "left_inner_cheek": Role(
        {"upper_lip_left": -0.8, "cheek_left": -0.4}, {"lip_corner_left": -1.0}
    ),
    "right_outer_cheek": Role({"cheek_right": -1.0}, {"lip_corner_right": -1.0, "lids_right": 1.0}),
    "left_outer_cheek": Role({"cheek_left": -1.0}, {"lip_corner_left": -1.0, "lids_left": 1.0}),
    "jaw": Role(
        {"jaw": 1.0},
        {
            "lip_corner_right": -1.0,
            "lip_corner_left": -1.0,
            "lip_pucker": 1.0,
            "lower_lip_right": 1.0,
            "lower_lip_left": 1.0,
        },
    ),
    "right_lip_corner": Role({"lip_corner_right": 1.0}, {"cheek_right": 1.0, "lip_pucker": -1.0}),
    "left_lip_corner": Role({"lip_corner_left": 1.0}, {"cheek_left": 1.0, "lip_pucker": -1.0}),
    "right_lower_lip": Role({"lower_lip_right": 1.0}, {"jaw": 1.0, "lower_lip_left": 1.0}),
    "left_lower_lip": Role({"lower_lip_left": 0.9}, {"jaw": 1.0, "lower_lip_right": 1.0}),
}

#: Pairs of servos whose roles a miswired head may swap.
SWAPS: Final = (
    ("right_eyebrow", "left_eyebrow"),
    ("right_eye_x", "left_eye_x"),
    ("right_eye_y", "left_eye_y"),
    ("right_eye_x", "right_eye_y"),
    ("left_eye_x", "left_eye_y"),
    ("right_inner_cheek", "left_inner_cheek"),
    ("right_outer_cheek", "left_outer_cheek"),
    ("right_inner_cheek", "right_outer_cheek"),
    ("left_inner_cheek", "left_outer_cheek"),
    ("right_lip_corner", "left_lip_corner"),
    ("right_lower_lip", "left_lower_lip"),
    ("right_lip_corner", "right_lower_lip"),
    ("left_lip_corner", "left_lower_lip"),
)

_EYES: Final = frozenset(name for name in SERVOS if "_eye_" in name)
_SEED: Final = re.compile(r"[0-9]{1,10}")


class _Draw:
    """Uniform draws from one seeded stream (``random()`` only: stable across versions)."""

    def __init__(self, seed: int) -> None:
        self._random = random.Random(seed)

    def chance(self, p: float) -> bool:
        return self._random.random() < p

    def uniform(self, low: float, high: float, digits: int = 3) -> float:
        return round(low + (high - low) * self._random.random(), digits)

    def index(self, n: int) -> int:
        return min(int(self._random.random() * n), n - 1)


def _wiring(draw: _Draw) -> tuple[dict[str, str], list[str]]:
    """Each servo's role (a servo name of :data:`ROLES`) and the swaps made, as words."""
    roles = {name: name for name in SERVOS}
    swaps = []
    for _ in range(draw.index(4)):  # 0-3 swaps of servos not swapped yet
        free = [pair for pair in SWAPS if all(roles[n] == n for n in pair)]
        if not free:
            break
        a, b = free[draw.index(len(free))]
        roles[a], roles[b] = b, a
        swaps.append(f"{a}<->{b}")
    return roles, swaps


def _actuator(draw: _Draw, channel: int, name: str, role: Role, dead: bool) -> Actuator:
    eye = name in _EYES
    curve = ("linear", "power", "power", "smoothstep", "smoothstep")[draw.index(5)]
    exponent = draw.uniform(0.6, 2.2, 2) if curve == "power" else 1.0
    min_us = 1000.0 if draw.chance(0.5) else draw.uniform(1000, 1120, 0)
    max_us = 2000.0 if draw.chance(0.5) else draw.uniform(1880, 2000, 0)
    rest_us = draw.uniform(1440, 1560, 0)
    dead_band = draw.uniform(2, 8, 1) if eye else draw.uniform(5, 18, 1)
    if draw.chance(0.1):
        dead_band = draw.uniform(60, 150, 0)
    strength = draw.uniform(0.75, 1.1, 2)
    coupling = {}
    for effect, sign in role.neighbours.items():
        if draw.chance(0.7):
            coupling[effect] = round(sign * draw.uniform(0.1, 0.5, 2), 2)
    return msgspec.convert(
        {
            "name": name,
            "channel": channel,
            "min_us": min_us,
            "max_us": max_us,
            "rest_us": rest_us,
            "dead_band_us": dead_band,
            "curve": curve,
            "exponent": exponent,
            "gain_up": draw.uniform(0.5, 1.15, 2),
            "gain_down": draw.uniform(0.5, 1.15, 2),
            "reversed": draw.chance(0.25),
            "slew_us_per_s": draw.uniform(3000, 6000, 0) if eye else draw.uniform(1500, 3000, 0),
            "lag_s": draw.uniform(0.02, 0.06) if eye else draw.uniform(0.05, 0.15),
            "effects": {} if dead else {e: round(a * strength, 3) for e, a in role.effects.items()},
            "coupling": {} if dead else coupling,
        },
        Actuator,
    )


def generate_head(seed: int) -> HeadConfig:
    """The head of ``seed`` (0 .. 2**32 - 1), named ``seed:N`` (see the module)."""
    if not 0 <= seed <= MAX_SEED:
        raise HeadError(f"head seed {seed} is not within 0..{MAX_SEED}")
    draw = _Draw(seed)
    roles, swaps = _wiring(draw)
    dead = SERVOS[draw.index(len(SERVOS))] if draw.chance(0.25) else None
    actuators = [
        _actuator(draw, channel, name, ROLES[roles[name]], name == dead)
        for channel, name in enumerate(SERVOS)
    ]
    reversed_ = [a.name for a in actuators if a.reversed]
    wiring = [
        f"swapped {', '.join(swaps) or 'none'}",
        f"reversed {', '.join(reversed_) or 'none'}",
        f"dead {dead or 'none'}",
    ]
    name = f"seed:{seed}"
    config = HeadConfig(
        name=name,
        description=f"generated from seed {seed} on head16_hardware's channels: "
        + "; ".join(wiring),
        actuators=actuators,
    )
    return _check(config, name)


def generated_seed(text: str) -> int | None:
    """The seed of a generated head's name (``seed:N``, ``generated:N``); None for another
    name; :class:`~.config.HeadError` for a malformed one."""
    prefix = next((p for p in PREFIXES if text.startswith(p)), None)
    if prefix is None:
        return None
    digits = text[len(prefix) :]
    if not _SEED.fullmatch(digits) or int(digits) > MAX_SEED:
        raise HeadError(
            f"head {text!r}: the seed must be a whole number within 0..{MAX_SEED} (e.g. {prefix}7)"
        )
    return int(digits)


def generated_head(text: str) -> HeadConfig:
    """The generated head named ``text`` (``seed:N`` or ``generated:N``)."""
    seed = generated_seed(text)
    if seed is None:
        raise HeadError(f"head {text!r} is not seed:N or generated:N")
    return generate_head(seed)
