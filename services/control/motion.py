"""Where each servo is, and how far it may move in one step: the profile's limits, enforced last.

Pure: the caller says how much time a step covers. Every position the control interface sends
goes through :meth:`FaceMotion.step`, so no command, restart, new translator or flood can move a
servo faster than its profile allows:

* a servo with ``max_speed`` (µs/s) and/or ``max_accel`` (µs/s²) moves toward its target within
  them (:func:`facesynth.runtime.motion.limit_step`, braking to stop at the target);
* a servo without ``max_speed`` moves at once, except while it *catches up*: after start-up,
  after the face returned to neutral, and when a new sender takes over, it moves at its full
  travel per ``neutral_ramp_s`` until it first reaches its target (the translator ramps the
  same way when the face comes back);
* a step never counts more than ``max_step_s``: after a pause the servo starts moving
  gradually, as if it had been commanded every ``max_step_s``, instead of jumping by all the
  time that passed.
"""

from __future__ import annotations

from collections.abc import Mapping

from facesynth.runtime.motion import limit_step
from facesynth.runtime.profiles import Profile

#: A step never covers more time than this (seconds). The control interface steps at least
#: this often while a servo has not reached its target.
MAX_STEP_S = 0.04
#: Closer than this to its target (µs), a servo has reached it.
REACHED_US = 1e-6


class FaceMotion:
    """Positions and velocities of one profile's servos, moved within their limits."""

    def __init__(self, profile: Profile, *, max_step_s: float = MAX_STEP_S) -> None:
        if not max_step_s > 0:
            raise ValueError("a motion step must cover a positive time")
        self.profile = profile
        self.max_step_s = max_step_s
        self._specs = {spec.name: spec for spec in profile.servos}
        self.positions: dict[str, float] = profile.neutral_positions()
        self.velocities: dict[str, float] = dict.fromkeys(self._specs, 0.0)
        ramp_s = max(0.0, profile.neutral_ramp_s)
        #: Catch-up speed of each servo without ``max_speed`` (µs/s; 0: none, it jumps).
        self.catch_up_speed = {
            spec.name: (spec.max_us - spec.min_us) / ramp_s if ramp_s > 0 else 0.0
            for spec in profile.servos
            if spec.max_speed <= 0
        }
        self.catching_up: set[str] = set()
        #: Per servo, what :meth:`step` reads of its spec, looked up once: name, limits, speed
        #: and acceleration bounds, catch-up speed.
        self._rows = [
            (
                spec.name,
                spec.min_us,
                spec.max_us,
                spec.max_speed,
                spec.max_accel,
                self.catch_up_speed.get(spec.name, 0.0),
            )
            for spec in profile.servos
        ]
        self.catch_up()

    def catch_up(self) -> None:
        """From now until each reaches its target, servos without ``max_speed`` move at their
        full travel per ``neutral_ramp_s`` (start-up, a resumed stream, a new sender)."""
        self.catching_up = {name for name, speed in self.catch_up_speed.items() if speed > 0}

    def speed_limit(self, name: str) -> float:
        """The speed bound of servo ``name`` now (µs/s; 0 = unlimited)."""
        spec = self._specs[name]
        if spec.max_speed > 0:
            return spec.max_speed
        return self.catch_up_speed[name] if name in self.catching_up else 0.0

    def step(self, targets: Mapping[str, float], dt_s: float) -> dict[str, float]:
        """Move every servo toward its target (servos not named hold theirs) for ``dt_s``.

        ``dt_s`` is capped at ``max_step_s``; 0 or less does not move a limited servo (a
        repeated instant), while a servo without limits is at its target at once.
        Targets are clamped to each servo's limits first.
        """
        dt = min(dt_s, self.max_step_s)
        positions, velocities, catching_up = self.positions, self.velocities, self.catching_up
        # (each servo's spec read once, in _rows; ServoSpec.clamp and speed_limit inlined,
        # the same arithmetic)
        for name, low, high, max_speed, accel, catch_up in self._rows:
            position, velocity = positions[name], velocities[name]
            target = min(max(targets.get(name, position), low), high)
            speed = max_speed if max_speed > 0 else (catch_up if name in catching_up else 0.0)
            if speed <= 0 and accel <= 0:
                position, velocity = target, 0.0  # unlimited: there at once
            elif dt <= 0:
                pass  # no time: no move
            else:
                position, velocity = limit_step(position, velocity, target, dt, speed, accel)
            if abs(position - target) <= REACHED_US:
                # Arrived: braking left at most one step's worth of speed, which stops here.
                position, velocity = target, 0.0
                catching_up.discard(name)
            clamped = min(max(position, low), high)
            positions[name] = clamped
            velocities[name] = velocity if clamped == position else 0.0
        return dict(positions)

    def reached(self, targets: Mapping[str, float]) -> bool:
        """Whether every servo is at its target (clamped) and still."""
        positions, velocities = self.positions, self.velocities
        for name, low, high, _, _, _ in self._rows:  # (ServoSpec.clamp inlined, as in step)
            position = positions[name]
            target = min(max(targets.get(name, position), low), high)
            if not (abs(position - target) <= REACHED_US and velocities[name] == 0.0):
                return False
        return True

    def max_step_us(self, name: str, dt_s: float) -> float:
        """The largest move of servo ``name`` in a step of ``dt_s`` (inf: unlimited)."""
        speed = self.speed_limit(name)
        return speed * min(dt_s, self.max_step_s) if speed > 0 else float("inf")
