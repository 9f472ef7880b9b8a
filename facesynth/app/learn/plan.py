"""The babbling plan: which pose comes next, in normalized units, deterministic given a seed.

Pure numpy. A pose is a vector ``u`` with one value per servo in [-1, 1]: 0 at the servo's
neutral, +1 at its ``max_us``, -1 at its ``min_us`` (as :meth:`BabbleSet.normalized` reads them
back). The plan is, in order:

1. a neutral pose, then **sweeps**: each servo alone, from neutral to its maximum and then to its
   minimum in ``sweep_steps`` steps each way (the others at neutral), which shows dead channels
   and dead bands;
2. **random** poses that fill the space: a scrambled Halton sequence (a random shift per
   dimension, drawn from the seed) over [-1, 1]^S;

with a neutral pose every ``neutral_every`` poses to re-check the neutral, and no servo held at
an extreme (``|u| > EXTREME``) more than ``max_extreme_run`` poses in a row (such a value is
pulled back to ``EXTREME``). Pose ``i`` depends on the seed and on the poses before it only, so a
resumed run computes the same plan and continues at its index.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from facesynth.runtime.profiles import Profile

#: Beyond this (normalized), a servo is at an extreme of its range.
EXTREME = 0.9
#: Prime bases of the Halton sequence, one per servo (up to 32 servos).
PRIMES: tuple[int, ...] = (
    *(2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53),
    *(59, 61, 67, 71, 73, 79, 83, 89, 97, 101, 103, 107, 109, 113, 127, 131),
)


class PlanError(ValueError):
    """Plan options that cannot be used."""


@dataclass(frozen=True)
class PlanOptions:
    """How the plan is made."""

    seed: int = 0
    sweep_steps: int = 3
    neutral_every: int = 25
    max_extreme_run: int = 2

    def __post_init__(self) -> None:
        if self.seed < 0:
            raise PlanError(f"--seed must be >= 0, not {self.seed}")
        if self.sweep_steps < 1:
            raise PlanError("the sweeps need at least one step each way")
        if self.neutral_every < 2:
            raise PlanError("a neutral pose at most every other pose")
        if self.max_extreme_run < 1:
            raise PlanError("an extreme may be held for at least one pose")


@dataclass(frozen=True)
class Pose:
    """One planned pose: its index, its kind and its normalized values (one per servo)."""

    index: int
    kind: str
    u: tuple[float, ...]


class BabblePlan(Protocol):
    """What the babbler asks of a plan: :class:`Plan`, or one that adapts to the faces it is
    told (:class:`~facesynth.app.learn.adaptive.AdaptivePlan`)."""

    def pose(self, index: int) -> Pose:
        """Pose ``index`` (from 0), asked for in order."""
        ...

    def seen(self, pose: Pose, features: Mapping[str, float]) -> None:
        """The settled face (raw features; empty: skipped, not seen) of ``pose``, the last
        pose asked for, before the next one is asked for."""
        ...


class PoseSequence:
    """Poses made one at a time, in order, and kept: pose ``i`` is made once, by ``_next(i)``,
    after every pose before it (:class:`Plan`, and the adaptive plan, whose next pose depends
    on the faces of the earlier ones)."""

    def __init__(self) -> None:
        self._poses: list[Pose] = []

    def pose(self, index: int) -> Pose:
        """Pose ``index`` (from 0); every pose before it is made first."""
        if index < 0:
            raise PlanError(f"pose index {index} < 0")
        while len(self._poses) <= index:
            self._poses.append(self._next(len(self._poses)))
        return self._poses[index]

    def _next(self, index: int) -> Pose:
        raise NotImplementedError


def halton(index: int, base: int) -> float:
    """The ``index``-th element (from 1) of the van der Corput sequence in ``base``."""
    result, fraction = 0.0, 1.0
    while index > 0:
        fraction /= base
        index, digit = divmod(index, base)
        result += digit * fraction
    return result


class Plan(PoseSequence):
    """The poses of a babbling session for ``servos`` (their count); see the module docstring."""

    def __init__(self, servos: int, options: PlanOptions | None = None) -> None:
        super().__init__()
        if not 1 <= servos <= len(PRIMES):
            raise PlanError(f"babbling plans cover 1 to {len(PRIMES)} servos, not {servos}")
        self.servos = servos
        self.options = options or PlanOptions()
        rng = np.random.default_rng(self.options.seed)
        self._shift = rng.random(servos)
        steps = self.options.sweep_steps
        levels = [k / steps for k in range(1, steps + 1)]
        self._sweeps: list[tuple[int, float]] = [
            (servo, sign * level)
            for servo in range(servos)
            for sign in (1.0, -1.0)
            for level in levels
        ]
        self._runs = [0] * servos
        self._random = 0

    @property
    def sweep_poses(self) -> int:
        """How many poses the first neutral and the sweeps take (neutral checks included)."""
        count, index = 0, 0
        while count < len(self._sweeps):
            index += 1
            if not self._is_neutral_slot(index):
                count += 1
        return index + 1

    def _is_neutral_slot(self, index: int) -> bool:
        return index % self.options.neutral_every == 0

    def _next(self, index: int) -> Pose:
        if self._is_neutral_slot(index):
            return self._limited(index, "neutral", np.zeros(self.servos))
        done = index - (index // self.options.neutral_every + 1)  # non-neutral poses before
        if done < len(self._sweeps):
            servo, value = self._sweeps[done]
            u = np.zeros(self.servos)
            u[servo] = value
            return self._limited(index, "sweep", u)
        self._random += 1
        point = np.array([halton(self._random, PRIMES[d]) for d in range(self.servos)])
        u = 2.0 * ((point + self._shift) % 1.0) - 1.0
        return self._limited(index, "random", u)

    def seen(self, pose: Pose, features: Mapping[str, float]) -> None:
        """This plan's poses do not depend on the faces: nothing to learn from them."""

    def limit(self, index: int, kind: str, u: np.ndarray) -> Pose:
        """Pose ``index`` of ``kind`` at ``u``, clipped and with no extreme held too long: for
        a plan that chooses its own poses after this one's sweeps (they must be asked for in
        order, after :meth:`pose` of every index before)."""
        return self._limited(index, kind, np.asarray(u, dtype=np.float64))

    def _limited(self, index: int, kind: str, u: np.ndarray) -> Pose:
        """``u`` clipped to [-1, 1], with no extreme held longer than allowed."""
        u = np.clip(u, -1.0, 1.0)
        for servo in range(self.servos):
            if abs(u[servo]) > EXTREME:
                if self._runs[servo] >= self.options.max_extreme_run:
                    u[servo] = EXTREME * np.sign(u[servo])
                    self._runs[servo] = 0
                else:
                    self._runs[servo] += 1
            else:
                self._runs[servo] = 0
        return Pose(index, kind, tuple(float(v) for v in u))


def to_pulses(profile: Profile, u: tuple[float, ...] | np.ndarray) -> dict[str, float]:
    """Normalized values (one per servo, in the profile's order) as pulse widths in µs, within
    each servo's limits."""
    if len(u) != len(profile.servos):
        raise PlanError(f"{len(u)} values for a profile of {len(profile.servos)} servos")
    positions = {}
    for spec, value in zip(profile.servos, u, strict=True):
        value = min(1.0, max(-1.0, float(value)))
        span = (spec.max_us - spec.neutral_us) if value >= 0 else (spec.neutral_us - spec.min_us)
        positions[spec.name] = spec.clamp(spec.neutral_us + value * span)
    return positions
