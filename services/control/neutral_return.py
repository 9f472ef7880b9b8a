"""Control interface C, pure: when the face goes back to neutral, and in which steps.

A :class:`Watchdog` says once, after a silence longer than its timeout, that the commands have
stopped; a :class:`Ramp` then takes the face from where it is to neutral in even steps
(:data:`RAMP_RATE_HZ` of them a second, over the profile's ``neutral_ramp_s``), which C's
speed limits still bound (:mod:`facesynth.services.control.motion`). The same ramp brings the
face to neutral on shutdown. Time is data: nanoseconds of the controller's monotonic clock.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Steps per second of a return to neutral.
RAMP_RATE_HZ = 25


class Watchdog:
    """Says once, after ``timeout_ns`` without a command, that the face should go neutral."""

    def __init__(self, timeout_s: float) -> None:
        if not timeout_s > 0:
            raise ValueError("the watchdog timeout must be positive")
        self.timeout_ns = int(timeout_s * 1e9)
        self._last_ns: int | None = None
        self._fired = True  # nothing to return from before the first command

    def feed(self, now_ns: int) -> None:
        """A command arrived."""
        self._last_ns = now_ns
        self._fired = False

    def due_ns(self) -> int | None:
        """When it fires if nothing arrives (``None``: it has nothing to fire for)."""
        if self._fired or self._last_ns is None:
            return None
        return self._last_ns + self.timeout_ns

    def expired(self, now_ns: int) -> bool:
        """True exactly once per silence longer than the timeout."""
        due = self.due_ns()
        if due is None or now_ns < due:
            return False
        self._fired = True
        return True


@dataclass
class Ramp:
    """An even return to neutral: step ``i`` of ``steps`` at ``start_ns + i * ramp_ns // steps``."""

    start_ns: int
    ramp_ns: int
    steps: int
    origin: dict[str, float]
    done: int = 0

    @classmethod
    def begin(cls, now_ns: int, ramp_s: float, origin: dict[str, float]) -> Ramp:
        """A return from ``origin`` (the servos' positions now) lasting ``ramp_s`` seconds."""
        steps = max(1, round(ramp_s * RAMP_RATE_HZ))
        return cls(now_ns, round(ramp_s * 1e9), steps, origin)

    def due_ns(self) -> int | None:
        """When the next step is due (``None``: every step is done)."""
        if self.done >= self.steps:
            return None
        return self.start_ns + self.ramp_ns * (self.done + 1) // self.steps

    def step(self, neutral: dict[str, float]) -> dict[str, float]:
        """The targets of the next step toward ``neutral``, counting it done."""
        self.done += 1
        fraction = self.done / self.steps
        return {
            name: origin + (neutral[name] - origin) * fraction
            for name, origin in self.origin.items()
        }
