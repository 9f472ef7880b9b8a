"""Signal filters for the translator, pure: a One Euro filter and a speed/acceleration limiter.

Time is given per sample in integer nanoseconds (``t_media_ns``), so replays give the same
output. Both keep their state between calls and have ``reset()``.

* :class:`OneEuroFilter` (Casiez, Roussel, Vogel, "1€ Filter", CHI 2012): an exponential
  low-pass whose cutoff rises with the signal's speed, ``cutoff = min_cutoff + beta * |dx/dt|``:
  strong smoothing at rest (no jitter), little lag in fast moves. The first sample passes
  through. A sample at the same time as the previous one (a repeated frame) returns the previous
  output; a sample earlier than the previous one (a looped replay) or after a gap longer than
  ``max_gap_s`` restarts the filter (passes through).
* :func:`limit_step` / :class:`RateLimiter`: moves a position toward a target no faster than
  ``max_speed`` and with a speed that changes no faster than ``max_accel``, braking so it stops
  at the target (0 = unlimited). A step longer than ``max_dt_s`` counts as ``max_dt_s``: after a
  gap in the input the servo still moves gradually.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: A gap in a signal longer than this restarts a One Euro filter (seconds).
DEFAULT_MAX_GAP_S = 0.5
#: A limiter step never counts more than this (seconds).
DEFAULT_MAX_DT_S = 0.25


def smoothing_factor(cutoff_hz: float, dt_s: float) -> float:
    """The exponential smoothing factor of a first-order low-pass at ``cutoff_hz`` for ``dt_s``."""
    tau = 1.0 / (2.0 * math.pi * cutoff_hz)
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
        if self._t_ns is not None:
            elapsed = t_ns - self._t_ns
            if elapsed == 0:
                return self._x
            if elapsed < 0 or elapsed > self.max_gap_ns:
                self.reset()
        if self._t_ns is None:
            self._t_ns, self._x, self._dx = t_ns, x, 0.0
            return x
        dt = (t_ns - self._t_ns) / 1e9
        dx = (x - self._x) / dt
        self._dx += smoothing_factor(self.d_cutoff, dt) * (dx - self._dx)
        cutoff = self.min_cutoff + self.beta * abs(self._dx)
        self._x += smoothing_factor(cutoff, dt) * (x - self._x)
        self._t_ns = t_ns
        return self._x


def braking_speed(distance: float, max_accel: float, dt_s: float) -> float:
    """The largest speed ``v`` from which steps of ``dt_s`` at ``v, v - a·dt, v - 2a·dt, …``
    (while positive) cover at most ``distance`` (>= 0): moving at it now, the limiter can still
    stop at the target."""
    step = max_accel * dt_s
    if distance <= 0:
        return 0.0
    # Covered from v = (k + f)·step, 0 <= f < 1: dt·step·((k + 1)·f + k(k + 1)/2).
    budget = distance / (dt_s * step)
    k = math.floor((math.sqrt(8.0 * budget + 1.0) - 1.0) / 2.0)
    while k * (k + 1) / 2 > budget:
        k -= 1
    while (k + 1) * (k + 2) / 2 <= budget:
        k += 1
    fraction = (budget - k * (k + 1) / 2) / (k + 1)
    return (k + min(fraction, 1.0)) * step


def limit_step(
    position: float,
    velocity: float,
    target: float,
    dt_s: float,
    max_speed: float = 0.0,
    max_accel: float = 0.0,
) -> tuple[float, float]:
    """``(position, velocity)`` after one step of ``dt_s`` toward ``target``.

    ``max_speed`` (units/s) and ``max_accel`` (units/s²) bound the move; 0 means unlimited.
    ``dt_s <= 0`` does not move.
    """
    if dt_s <= 0:
        return position, velocity
    error = target - position
    speed = abs(error) / dt_s  # reach the target in this step, no overshoot
    if max_speed > 0:
        speed = min(speed, max_speed)
    if max_accel > 0:
        speed = min(speed, braking_speed(abs(error), max_accel, dt_s))
        wanted = math.copysign(speed, error)
        change = max_accel * dt_s
        new_velocity = min(max(wanted, velocity - change), velocity + change)
    else:
        new_velocity = math.copysign(speed, error)
    new_position = position + new_velocity * dt_s
    if max_accel <= 0 and (target - new_position) * error <= 0:
        new_position = target  # reached (without an acceleration bound, never past it)
    return new_position, new_velocity


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
