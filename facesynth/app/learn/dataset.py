"""The babbling data set: every settled pose's commands and the face the camera saw.

The seam between the babbling session (which reads a recorded session into a
:class:`BabbleSet`) and the fitting (:mod:`facesynth.app.learn.fit`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from facesynth.runtime.profiles import Profile

#: What a sample is: the neutral pose re-checked, a single-channel sweep step, a random pose.
KINDS = ("neutral", "sweep", "random")


@dataclass(frozen=True)
class BabbleSet:
    """Settled babbling poses, one row each.

    Attributes:
        servos: the profile's servo names, in column order of ``commands``.
        commands: (N, S) pulses in µs, as commanded (and reached) for each pose.
        inputs: feature names, in column order of ``faces``.
        faces: (N, F) ``Features.raw`` values of the settled face (NaN where absent).
        kinds: per sample, one of :data:`KINDS`.
        lags: per servo, the head's response lag (s) where the babbling measured it
            (:mod:`facesynth.app.learn.lag`, the fit reports it; empty: not measured).
    """

    servos: tuple[str, ...]
    commands: np.ndarray
    inputs: tuple[str, ...]
    faces: np.ndarray
    kinds: tuple[str, ...]
    lags: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.kinds)
        if self.commands.shape != (n, len(self.servos)):
            raise ValueError(
                f"commands shape {self.commands.shape} is not ({n}, {len(self.servos)})"
            )
        if self.faces.shape != (n, len(self.inputs)):
            raise ValueError(f"faces shape {self.faces.shape} is not ({n}, {len(self.inputs)})")
        unknown = sorted(set(self.kinds) - set(KINDS))
        if unknown:
            raise ValueError(f"unknown sample kinds {unknown}; known: {', '.join(KINDS)}")

    def __len__(self) -> int:
        return len(self.kinds)

    def normalized(self, profile: Profile) -> np.ndarray:
        """(N, S) commands in [-1, 1]: 0 at each servo's neutral, +1 at max_us, -1 at min_us."""
        specs = [profile.servo(name) for name in self.servos]
        neutral = np.array([s.neutral_us for s in specs])
        up = np.array([s.max_us - s.neutral_us for s in specs])
        down = np.array([s.neutral_us - s.min_us for s in specs])
        delta = self.commands - neutral
        scale = np.where(delta >= 0, np.where(up > 0, up, 1.0), np.where(down > 0, down, 1.0))
        out: np.ndarray = np.clip(delta / scale, -1.0, 1.0)
        return out
