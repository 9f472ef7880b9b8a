"""Translator T, pure core: features to servo positions (the paper's section 2.2.3, extended).

Per frame, per servo:

1. **Source value.** A ``points`` servo takes the mean delta of its point group (the paper);
   a ``feature`` (or ``blendshape``) servo one named feature (``Features.named``, scaled: 0
   neutral, ±1 the calibrated extremes); a ``mix`` servo the weighted sum of named features
   (an antagonist pair on one servo). With ``mirror``, right and left are swapped first (and x
   directions negated).
   ``points`` given with ``feature``/``mix`` are a fallback, used only while no frame since the
   start (or :meth:`Translator.reset`) has carried the named features.
2. **Smoothing.** Each distinct signal used (a point group, a named feature) goes through its
   own One Euro filter (:mod:`services.translator.filters`), with time from ``t_media_ns``.
   Point groups are filtered in range units (divided by half their face range), so one set of
   parameters fits groups and named features alike.
3. **Dead-band, gain, one side.** ``|value| <= deadband`` gives 0, beyond it the dead-band is
   subtracted (continuous); then the value is multiplied by ``gain``; a ``one_sided`` servo
   takes negative values as 0 (neutral), so a mouth more closed than the neutral's never drives
   the jaw past closed. The dead-band is in source units (IOD
   for points, scaled for named features; for points used as a fallback of named features, it
   is taken in scaled units, i.e. times half the group's face range).
4. **Mapping.** Points: linearly from the face range [face_min, 0, face_max] (profile default or
   calibration) onto [min_us, neutral_us, max_us]; named: ``+1 -> max_us``, ``-1 -> min_us``.
   Reversed servos swap the directions. The target is clamped to the servo's limits.
5. **Missing input.** A servo whose source is absent from a tracked frame (a named feature the
   stream lacks, no deltas) holds its position. While no face is tracked, or the neutral is not
   known yet, the target is neutral.
6. **Motion.** Targets go through a rate limiter per servo (``max_speed`` µs/s, ``max_accel``
   µs/s², 0 = unlimited). A servo without ``max_speed`` is still ramped on a change of tracking
   state: when the face is lost it goes to neutral linearly in ``neutral_ramp_s``; when the face
   comes back it catches up at its full travel per ``neutral_ramp_s``, then tracks unlimited.
7. **Safety.** Exclusive rules (:mod:`services.translator.safety`) on targets and on outputs,
   then every position is clamped to its limits (always last).

Steps 1-4 are each servo's own (:mod:`facesynth.services.translator.sources`). A learned
profile replaces them with :mod:`services.translator.learned`; a hardware profile
(servos without a source) that is not learned is refused. Its loop can be closed through the
robot's own camera (:meth:`Translator.close_loop`, the robot's faces given to
:meth:`Translator.observe`; :mod:`facesynth.services.translator.closed_loop`): each command is
then corrected before smoothing, on the clock ``now_ns`` of :meth:`Translator.step`.

The first frame after construction or :meth:`Translator.reset` initialises every filter and
limiter (no history to smooth or limit against). In a chain this is a neutral frame: F needs a
second of face before its neutral is ready. :meth:`Translator.resume` starts the limiters where
the control interface says the servos are instead (the service does so when it starts, when
its input resumes after a gap, and when the controller moved on its own).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from facesynth.runtime.calibration import Calibration
from facesynth.runtime.landmarks import MIRROR, N_IBUG
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.translator.closed_loop import ClosedLoop, LoopOptions, LoopState
from facesynth.services.translator.learned import learned_targets, unsourced
from facesynth.services.translator.mapping import (
    deadband,
    interpolate,
    mirror_named,
    scaled_position,
)
from facesynth.services.translator.safety import apply_exclusive
from facesynth.services.translator.sources import (
    Filters,
    GroupMeans,
    ServoWiring,
    face_range,
    smoothing_filter,
)

Raw = Mapping[str, float] | None  # Features.raw (a learned profile's inputs)

# The mapping functions are imported from here too (tests, older callers).
__all__ = [
    "TranslationError",
    "Translator",
    "deadband",
    "interpolate",
    "mirror_named",
    "scaled_position",
]


class TranslationError(ValueError):
    """Features that cannot be translated with this profile."""


class Translator:
    """Features messages in, ServoCommands messages out, for one profile (stateful)."""

    def __init__(self, profile: Profile, calibration: Calibration | None = None) -> None:
        if problem := unsourced(profile):
            raise TranslationError(problem)
        self.profile = profile
        self._specs = {spec.name: spec for spec in profile.servos}
        self._ranges = [face_range(spec, calibration, profile.mirror) for spec in profile.servos]
        self._servos = [
            ServoWiring(spec, servo_range, profile.smoothing_for(spec))
            for spec, servo_range in zip(profile.servos, self._ranges, strict=True)
        ]
        self._means = GroupMeans(servo.points for servo in self._servos)
        self._filters: Filters = {}
        for servo in self._servos:
            servo.add_filters(self._filters)
        self._learned = learned_targets(profile, self._filters, smoothing_filter)  # learned
        self.reset()

    def reset(self) -> None:
        """Forget every filter and limiter: the next frame starts afresh."""
        for flt in self._filters.values():
            if flt is not None:
                flt.reset()
        for servo in self._servos:
            servo.limiter.reset()
            servo.seen = False
            servo.ramp = None
        self._tracking: bool | None = None
        if self._learned is not None:
            self._learned.reset()
            if self._learned.closed is not None:
                self._learned.closed.reset()

    def neutral(self) -> dict[str, float]:
        """Every servo at neutral."""
        return self.profile.neutral_positions()

    def is_at(self, positions: Mapping[str, float], tolerance_us: float = 1e-6) -> bool:
        """Whether every servo's limiter already stands, still, at ``positions`` (missing
        names: neutral), so resuming from there would change nothing but the filters."""
        for servo in self._servos:
            limiter, spec = servo.limiter, servo.spec
            wanted = positions.get(spec.name, spec.neutral_us)
            if limiter.position is None or limiter.velocity != 0.0:
                return False
            if abs(limiter.position - wanted) > tolerance_us:
                return False
        return True

    def resume(self, positions: Mapping[str, float]) -> None:
        """The servos are at ``positions`` now (where the control interface reports them):
        the next frame starts from there instead of from wherever this translator left off.

        Filters restart; each limiter starts at its servo's position (clamped; neutral for a
        servo not named), still; servos without ``max_speed`` catch up at their full travel
        per ``neutral_ramp_s``, as when the face comes back.
        """
        for flt in self._filters.values():
            if flt is not None:
                flt.reset()
        if self._learned is not None:
            self._learned.reset()
        ramp_s = self.profile.neutral_ramp_s
        for servo in self._servos:
            spec = servo.spec
            position = positions.get(spec.name, spec.neutral_us)
            if not math.isfinite(position):
                position = spec.neutral_us
            servo.limiter.reset(spec.clamp(position))
            catch_up = spec.max_speed <= 0 and ramp_s > 0
            servo.ramp = (spec.max_us - spec.min_us) / ramp_s if catch_up else None
        self._tracking = None

    # --- sources --------------------------------------------------------------------------

    def _deltas(self, deltas: list[float] | np.ndarray) -> np.ndarray:
        array = np.asarray(deltas, dtype=np.float64)
        if array.shape != (N_IBUG,):
            raise TranslationError(f"need {N_IBUG} deltas, got {array.shape[0]}")
        return array[MIRROR] if self.profile.mirror else array

    def _targets(
        self,
        deltas: np.ndarray | None,
        named: Mapping[str, float],
        t_ns: int | None,
        raw: Raw,
        now_ns: int | None = None,
    ) -> list[float | None]:
        if self._learned is not None:  # facesynth.services.translator.learned
            return self._learned.targets(raw or {}, named, t_ns, now_ns)
        cache: dict[object, float] = {}
        means = None if deltas is None else self._means(deltas)
        return [servo.target(means, named, t_ns, self._filters, cache) for servo in self._servos]

    def positions(
        self, deltas: np.ndarray, named: Mapping[str, float] | None = None, raw: Raw = None
    ) -> dict[str, float]:
        """Unfiltered, unlimited positions for 68 deltas (and named, raw features) from neutral.

        Stateless: the paper's mapping per servo; servos whose source is missing are at neutral.
        """
        array = self._deltas(deltas)
        named = mirror_named(named or {}) if self.profile.mirror else (named or {})
        raw = mirror_named(raw) if raw and self.profile.mirror else raw
        saved = [servo.seen for servo in self._servos]
        targets = self._targets(array, named, None, raw)
        for servo, seen in zip(self._servos, saved, strict=True):
            servo.seen = seen
        return {
            servo.spec.name: servo.spec.neutral_us if target is None else target
            for servo, target in zip(self._servos, targets, strict=True)
        }

    # --- one frame ------------------------------------------------------------------------

    def _start_ramps(self, tracking: bool) -> None:
        """A change of tracking state: ramp the servos that have no speed bound."""
        ramp_s = self.profile.neutral_ramp_s
        for servo in self._servos:
            spec, position = servo.spec, servo.limiter.position
            if spec.max_speed > 0 or ramp_s <= 0 or position is None:
                servo.ramp = None
            elif tracking:
                servo.ramp = (spec.max_us - spec.min_us) / ramp_s
            else:
                distance = abs(position - spec.neutral_us)
                servo.ramp = distance / ramp_s if distance > 0 else None

    def _move(self, servo: ServoWiring, target: float, t_ns: int) -> float:
        limiter = servo.limiter
        if servo.unlimited:
            limiter.position, limiter.velocity, limiter.t_ns = target, 0.0, t_ns
            return target
        position = limiter(target, t_ns, servo.ramp)
        if servo.ramp is not None and abs(position - target) < 1e-6:
            servo.ramp = None
        return position

    def close_loop(
        self, options: LoopOptions | None = None, state: LoopState | None = None
    ) -> ClosedLoop:
        """Correct a learned profile's commands through the robot's observed face from now on
        (:meth:`observe`; :mod:`facesynth.services.translator.closed_loop`)."""
        if self._learned is None:
            raise TranslationError(f"profile {self.profile.name} is not learned: no closed loop")
        try:
            return self._learned.close_loop(options, state)
        except ValueError as exc:
            raise TranslationError(f"profile {self.profile.name}: {exc}") from None

    def close_loop_once(self) -> ClosedLoop:
        """The loop closed by :meth:`close_loop` (closed now, with its defaults, if not yet)."""
        closed = self._learned.closed if self._learned is not None else None
        return closed if closed is not None else self.close_loop()

    def observe(self, features: Features) -> None:
        """The robot's own face, as its camera's tracker and F saw it at ``t_capture_ns``
        (no face or no neutral: lost); a no-op unless the loop is closed."""
        learned = self._learned
        if learned is None or learned.closed is None:
            return
        seen = features.face and features.neutral_ready and features.raw
        face = learned.observed(features.raw) if seen else None
        learned.closed.observe(face, features.t_capture_ns)

    def step(self, features: Features, now_ns: int | None = None) -> dict[str, float]:
        """Servo positions for one frame; updates the filters and limiters. ``now_ns``: the
        instant on the robot camera's clock (default the frame's ``t_capture_ns``), for a
        closed loop."""
        t_ns = features.t_media_ns
        now_ns = features.t_capture_ns if now_ns is None else now_ns
        tracking = features.face and features.neutral_ready
        deltas = self._deltas(features.deltas) if tracking and features.deltas else None
        named: Mapping[str, float] = {}
        raw_in: Mapping[str, float] = {}
        if tracking:
            named = mirror_named(features.named) if self.profile.mirror else features.named
            if self._learned is not None:
                raw_in = mirror_named(features.raw) if self.profile.mirror else features.raw
            tracking = deltas is not None or bool(named) or bool(raw_in)
        raw = (
            self._targets(deltas, named, t_ns, raw_in, now_ns)
            if tracking
            else [None] * len(self._servos)
        )
        targets = {}
        for servo, target in zip(self._servos, raw, strict=True):
            spec = servo.spec
            if not tracking:
                target = spec.neutral_us
            elif target is None:  # missing source: hold
                held = servo.limiter.position
                target = spec.neutral_us if held is None else held
            targets[spec.name] = target
        rules = self.profile.safety.exclusive
        if rules:  # (without rules the positions stand as they are)
            targets = apply_exclusive(targets, rules, self._specs)
        if self._tracking is not None and tracking != self._tracking:
            self._start_ramps(tracking)
        self._tracking = tracking
        out = {
            servo.spec.name: self._move(servo, targets[servo.spec.name], t_ns)
            for servo in self._servos
        }
        # (without rules nothing is pulled back: ``out`` itself is clamped below)
        safe = apply_exclusive(out, rules, self._specs) if rules else out
        for servo in self._servos:
            name = servo.spec.name
            if safe[name] != out[name]:
                servo.limiter.position, servo.limiter.velocity = safe[name], 0.0
            safe[name] = servo.spec.clamp(safe[name])
        if self._learned is not None:
            self._learned.sent(safe, now_ns)
        return safe

    def translate(self, features: Features, now_ns: int | None = None) -> ServoCommands:
        """Servo commands for one frame's features (``now_ns``: see :meth:`step`)."""
        return ServoCommands(
            seq=features.seq,
            t_capture_ns=features.t_capture_ns,
            t_media_ns=features.t_media_ns,
            face=features.face,
            profile=self.profile.name,
            positions=self.step(features, now_ns),
            capture_host=features.capture_host,
        )
