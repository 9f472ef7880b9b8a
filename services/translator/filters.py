"""Signal filters for the translator, pure: a One Euro filter and a speed/acceleration limiter.

Time is given per sample in integer nanoseconds (``t_media_ns``), so replays give the same
output. Both keep their state between calls and have ``reset()``.

* :class:`OneEuroFilter` (Casiez, Roussel, Vogel, "1€ Filter", CHI 2012): an exponential
  low-pass whose cutoff rises with the signal's speed, ``cutoff = min_cutoff + beta * |dx/dt|``:
  strong smoothing at rest (no jitter), little lag in fast moves. The first sample passes
  through. A sample at the same time as the previous one (a repeated frame) returns the previous
  output; a sample earlier than the previous one (a looped replay) or after a gap longer than
  ``max_gap_s`` restarts the filter (passes through).
* :class:`RateLimiter` (with :func:`facesynth.runtime.motion.limit_step`): moves a position
  toward a target no faster than ``max_speed`` and with a speed that changes no faster than
  ``max_accel``, braking so it stops at the target (0 = unlimited). A step longer than
  ``max_dt_s`` counts as ``max_dt_s``: after a gap in the input the servo still moves gradually.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from facesynth.runtime.motion import braking_speed, limit_step

__all__ = [
    "DEFAULT_MAX_DT_S",
    "DEFAULT_MAX_GAP_S",
    "OneEuroFilter",
    "RateLimiter",
    "braking_speed",
    "limit_step",
    "smoothing_factor",
]

#: A gap in a signal longer than this restarts a One Euro filter (seconds).
DEFAULT_MAX_GAP_S = 0.5
#: A limiter step never counts more than this (seconds).
DEFAULT_MAX_DT_S = 0.25
_TWO_PI = 2.0 * math.pi  # (how smoothing_factor's product starts)


def smoothing_factor(cutoff_hz: float, dt_s: float) -> float:
    """The exponential smoothing factor of a first-order low-pass at ``cutoff_hz`` for ``dt_s``."""
    tau = 1.0 / (_TWO_PI * cutoff_hz)
    return 1.0 / (1.0 + tau / dt_s)


class OneEuroFilter:
    """One Euro filter on one scalar signal."""

    def __init__(
        self,
        min_cutoff: float,
        beta: float,
        d_cutoff: float,
        *,
        max_gap_s: float = DEFAULT_MAX_GAP_S,
    ) -> None:
        if not (min_cutoff > 0 and d_cutoff > 0 and beta >= 0 and max_gap_s > 0):
            raise ValueError("One Euro filter needs min_cutoff, d_cutoff, max_gap_s > 0, beta >= 0")
        self.min_cutoff = min_cutoff
        self.beta = beta
        self.d_cutoff = d_cutoff
        self.max_gap_ns = round(max_gap_s * 1e9)
        self.reset()

    def reset(self) -> None:
        """Forget the signal: the next sample passes through."""
        self._t_ns: int | None = None
        self._x = 0.0
        self._dx = 0.0

    @property
    def value(self) -> float | None:
        """The last output (None before the first sample)."""
        return None if self._t_ns is None else self._x

    def __call__(self, x: float, t_ns: int) -> float:
        """The filtered value of sample ``x`` taken at ``t_ns``."""
        last = self._t_ns
        if last is not None:
            elapsed = t_ns - last
            if elapsed == 0:
                return self._x
            if elapsed < 0 or elapsed > self.max_gap_ns:
                last = None  # a restart: this sample passes through
        if last is None:
            self._t_ns, self._x, self._dx = t_ns, x, 0.0
            return x
        dt = elapsed / 1e9
        previous, slope = self._x, self._dx
        dx = (x - previous) / dt
        # smoothing_factor(cutoff, dt) inlined twice, the same arithmetic, for a call's CPU each
        slope += 1.0 / (1.0 + 1.0 / (_TWO_PI * self.d_cutoff) / dt) * (dx - slope)
        cutoff = self.min_cutoff + self.beta * abs(slope)
        previous += 1.0 / (1.0 + 1.0 / (_TWO_PI * cutoff) / dt) * (x - previous)
        self._t_ns, self._x, self._dx = t_ns, previous, slope
        return previous


@dataclass
class RateLimiter:
    """A position that follows targets within a speed and acceleration bound."""

    max_speed: float = 0.0
    max_accel: float = 0.0
    max_dt_s: float = DEFAULT_MAX_DT_S
    position: float | None = None
    velocity: float = 0.0
    t_ns: int | None = None

    def reset(self, position: float | None = None) -> None:
        """Forget the motion; the next target is taken as is (or start at ``position``)."""
        self.position = position
        self.velocity = 0.0
        self.t_ns = None

    def __call__(self, target: float, t_ns: int, max_speed: float | None = None) -> float:
        """The position at ``t_ns`` heading for ``target`` (``max_speed`` overrides the bound)."""
        if self.position is None:
            self.position, self.velocity, self.t_ns = target, 0.0, t_ns
            return target
        if self.t_ns is None:  # started at a position: the clock starts now
            self.t_ns = t_ns
            return self.position
        elapsed = (t_ns - self.t_ns) / 1e9
        if elapsed <= 0:  # a repeated frame holds; time going back (a looped replay) restarts
            self.t_ns = t_ns
            return self.position
        dt = min(elapsed, self.max_dt_s)
        self.t_ns = t_ns
        speed = self.max_speed if max_speed is None else max_speed
        self.position, self.velocity = limit_step(
            self.position, self.velocity, target, dt, speed, self.max_accel
        )
        return self.position
