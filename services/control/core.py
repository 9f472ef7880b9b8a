"""Control interface C, pure core: checks every command against the profile before a servo moves.

Commands for another profile, or naming servos the profile does not have, are refused whole
(never half applied). Every position is clamped to its servo's limits, whatever T computed.
Servos a command leaves out hold their last position. A watchdog says when commands have
stopped, so the shell can return the face to neutral.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from facesynth.runtime.profiles import Profile
from schemas.messages import ServoCommands


class CommandError(ValueError):
    """Servo commands this controller must not execute; the message says why."""


@dataclass(frozen=True, slots=True)
class CommandInfo:
    """Where a set of positions came from, for drivers that log it."""

    frame: int | None
    t_capture_ns: int | None
    face: bool


class ControlCore:
    """Validated, clamped servo positions for one profile."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self._specs = {spec.name: spec for spec in profile.servos}
        self.last: dict[str, float] = profile.neutral_positions()

    def accept(self, commands: ServoCommands) -> dict[str, float]:
        """Positions to send for ``commands``, or raise :class:`CommandError`."""
        if commands.profile != self.profile.name:
            raise CommandError(
                f"commands are for profile {commands.profile!r}; "
                f"this controller drives {self.profile.name!r}"
            )
        unknown = sorted(set(commands.positions) - set(self._specs))
        if unknown:
            raise CommandError(f"unknown servos for profile {self.profile.name!r}: {unknown}")
        for name, value in commands.positions.items():
            if math.isnan(value):
                raise CommandError(f"position of {name!r} is {value}")
        positions = dict(self.last)
        for name, value in commands.positions.items():
            positions[name] = self._specs[name].clamp(value)
        self.last = positions
        return positions

    def neutral(self) -> dict[str, float]:
        """Every servo at neutral (and remembered as the last position)."""
        self.last = self.profile.neutral_positions()
        return dict(self.last)

    def ramp_to_neutral(self, steps: int) -> list[dict[str, float]]:
        """Positions that take the face from where it is to neutral in ``steps`` even steps.

        The last one is exactly neutral; each is remembered as the last position when sent
        (call :meth:`mark_sent`), so a ramp interrupted by new commands resumes from there.
        """
        start = dict(self.last)
        target = self.profile.neutral_positions()
        count = max(1, steps)
        return [
            {name: start[name] + (target[name] - start[name]) * (i / count) for name in target}
            for i in range(1, count + 1)
        ]

    def mark_sent(self, positions: dict[str, float]) -> None:
        """Remember positions sent outside :meth:`accept` (a ramp step)."""
        self.last = dict(positions)


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

    def expired(self, now_ns: int) -> bool:
        """True exactly once per silence longer than the timeout."""
        if self._fired or self._last_ns is None:
            return False
        if now_ns - self._last_ns >= self.timeout_ns:
            self._fired = True
            return True
        return False
