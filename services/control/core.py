"""Control interface C, pure core: what reaches the servos, when, and how fast.

Every command is checked against the profile before a servo moves: commands for another
profile, with more positions than the profile has servos, naming servos it does not have, or
with a NaN position are refused whole (never half applied); every position is clamped to its
servo's limits. Commands older than the profile's ``max_command_age_s`` (since their sender sent
them, or since their frame was captured), or not newer than one already applied from the same
sender, are refused too (:mod:`facesynth.services.control.freshness`). A command's capture is
judged again at the last moment, as the shell hands its move to the driver
(:meth:`ControlCore.hand_over`): one that grew too old since it was taken (a loaded machine, a
pause) is withdrawn, as if it never came, and the face holds (then the watchdog's return).

Then nothing moves faster than the profile allows (:mod:`services.control.motion`): each step
toward the commanded targets is bounded by each servo's ``max_speed`` and ``max_accel``,
measured on the controller's own clock (``motion_time="real"``, the default) or, for a
``--fast`` replay to a file or a virtual face, on the commands' media time
(``motion_time="media"``: deterministic, and never for a real head). The core also moves on its
own (:meth:`ControlCore.tick`), as :class:`Move` s of other kinds:

* ``start``: the face at neutral when the controller starts; from there every servo without
  ``max_speed`` catches up at its full travel per ``neutral_ramp_s``;
* ``catch-up``: a servo still short of its target is stepped every ``MAX_STEP_S`` (real time
  only), so a command arriving after a pause or a target far away is reached gradually;
* ``return``: after ``watchdog_s`` without a command the face returns to neutral, in even steps
  over ``neutral_ramp_s`` (and never faster than each servo's limits;
  :mod:`facesynth.services.control.neutral_return`);
* ``stop``: the same return on shutdown (:meth:`ControlCore.stop`);
* ``report``: nothing moves, but where the servos are is published every ``report_s`` while
  nothing else is, so a translator that starts can learn where the face is.

Time is data: the shell passes its clock's readings in nanoseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.freshness import (
    Arrival,
    Freshness,
    StaleCapture,
    StaleCommand,
    Verdict,
)
from facesynth.services.control.motion import MAX_STEP_S, FaceMotion
from facesynth.services.control.neutral_return import RAMP_RATE_HZ, Ramp, Watchdog
from facesynth.services.control.undo import Undo

__all__ = [
    "MAX_STEP_S",
    "RAMP_RATE_HZ",
    "REPORT_S",
    "Arrival",
    "CommandError",
    "CommandInfo",
    "ControlCore",
    "Move",
    "StaleCommand",
]

#: While nothing else is published, where the servos are is reported this often (seconds).
REPORT_S = 0.5

MotionTime = Literal["real", "media"]
MoveKind = Literal["start", "command", "catch-up", "return", "stop", "report"]


class CommandError(ValueError):
    """Servo commands this controller must not execute; the message says why."""


@dataclass(frozen=True, slots=True)
class CommandInfo:
    """Where a set of positions came from, for drivers that log it; ``t_ns`` is the control
    interface's wall clock when it decided them (``None`` when a caller does not say)."""

    frame: int | None
    t_capture_ns: int | None
    face: bool
    t_ns: int | None = None

    def at(self, t_ns: int) -> CommandInfo:
        """The same, decided at ``t_ns`` (``dataclasses.replace``'s result, without its
        look at every field)."""
        return CommandInfo(self.frame, self.t_capture_ns, self.face, t_ns)


#: What drivers are told about a move of the controller's own.
OWN_MOVE = CommandInfo(frame=None, t_capture_ns=None, face=False)


@dataclass(frozen=True, slots=True)
class Move:
    """Positions to send now (``send``) and report on ``…/servo_state``, and why; ``t_ns`` is
    the (monotonic) instant the speed limits stepped them to; ``deadline_ns`` the controller's
    wall clock after which a command's capture is too old to hand it to the driver (``None``:
    not aged from capture, or not a command)."""

    kind: MoveKind
    positions: dict[str, float]
    info: CommandInfo = OWN_MOVE
    send: bool = True
    t_ns: int = 0
    deadline_ns: int | None = None

    @property
    def command(self) -> bool:
        """Whether a command asked for these positions (else the controller moved on its own)."""
        return self.kind == "command"

    @property
    def following(self) -> bool:
        """Whether the controller is following a sender's commands (a command, or a step on its
        way to the last one's targets): a translator that sees anything else resumes from
        the reported positions."""
        return self.kind in ("command", "catch-up")


class ControlCore:
    """Validated, clamped, fresh, speed-limited servo positions for one profile."""

    def __init__(
        self,
        profile: Profile,
        *,
        watchdog_s: float = 0.5,
        motion_time: MotionTime = "real",
        own_host: str = "",
        report_s: float = REPORT_S,
    ) -> None:
        if motion_time not in ("real", "media"):
            raise ValueError(f"motion_time is 'real' or 'media', not {motion_time!r}")
        if not report_s > 0:
            raise ValueError("the report interval must be positive")
        self.profile = profile
        self._specs = {spec.name: spec for spec in profile.servos}
        self._limits = {spec.name: (spec.min_us, spec.max_us) for spec in profile.servos}
        #: The last command :meth:`check` passed (frozen) and its targets: checked on arrival,
        #: it is not checked again by :meth:`command`.
        self._passed: tuple[ServoCommands, dict[str, float]] | None = None
        self.motion = FaceMotion(profile)
        self.freshness = Freshness(profile.max_command_age_s, own_host)
        self.watchdog = Watchdog(watchdog_s)
        self.motion_time = motion_time
        self.ramp_s = max(0.0, profile.neutral_ramp_s)
        self.report_ns = round(report_s * 1e9)
        self.neutral_positions = profile.neutral_positions()
        self.targets = dict(self.neutral_positions)
        self.mode: Literal["idle", "follow", "return", "stop"] = "idle"
        self.last_command: ServoCommands | None = None
        self._ramp: Ramp | None = None
        self._last_step_ns: int | None = None
        self._last_media_ns: int | None = None
        self._last_report_ns: int | None = None
        #: The last command's move and the state before it, until it is handed over.
        self._pending: tuple[Move, Undo] | None = None
        #: Commands withdrawn at the hand-over, in all, and in the current run of them.
        self.late = 0
        self._late_run = 0

    @property
    def positions(self) -> dict[str, float]:
        """Where the servos were last sent."""
        return dict(self.motion.positions)

    # --- commands ---------------------------------------------------------------------------

    def check(self, commands: ServoCommands) -> dict[str, float]:
        """The clamped targets ``commands`` asks for, or raise :class:`CommandError`."""
        if (passed := self._passed) is not None and passed[0] is commands:  # (one read)
            return dict(passed[1])
        if commands.profile != self.profile.name:
            raise CommandError(
                f"commands are for profile {commands.profile!r}; "
                f"this controller drives {self.profile.name!r}"
            )
        if len(commands.positions) > len(self._specs):
            raise CommandError(
                f"{len(commands.positions)} positions for a profile of {len(self._specs)} servos"
            )
        unknown = sorted(commands.positions.keys() - self._limits.keys())
        if unknown:
            raise CommandError(f"unknown servos for profile {self.profile.name!r}: {unknown}")
        limits, clamped = self._limits, {}
        for name, value in commands.positions.items():
            if math.isnan(value):
                raise CommandError(f"position of {name!r} is {value}")
            low, high = limits[name]
            clamped[name] = min(max(value, low), high)  # ServoSpec.clamp
        self._passed = (commands, clamped)
        return dict(clamped)

    def start(self, now_ns: int) -> Move:
        """The face at neutral as the controller starts."""
        self._last_step_ns = self._last_report_ns = now_ns
        self.motion.catch_up()
        return Move("start", self.positions, t_ns=now_ns)

    def command(self, commands: ServoCommands, arrival: Arrival) -> tuple[Move, Verdict]:
        """Take a command (checked, fresh) and step toward it; raise ``ValueError`` subclasses
        :class:`CommandError` or :class:`StaleCommand` for a command that must not run."""
        if self.mode == "stop":
            raise CommandError("the controller is stopping")
        wanted = self.check(commands)
        before = Undo.of(self, commands.sender)
        verdict = self.freshness.check(commands, arrival)
        base = self.targets if self.mode == "follow" else self.positions
        if self.mode != "follow" or verdict.new_sender:
            self.motion.catch_up()
        self.targets = {**base, **wanted}
        self.mode, self._ramp = "follow", None
        if self.motion_time == "media":
            previous = self._last_media_ns
            dt_ns = MAX_STEP_S * 1e9 if previous is None else commands.t_media_ns - previous
            self._last_media_ns = commands.t_media_ns
        else:
            dt_ns = arrival.mono_ns - self._step_origin(arrival.mono_ns)
        positions = self.motion.step(self.targets, dt_ns / 1e9)
        self._last_step_ns = self._last_report_ns = arrival.mono_ns
        self.watchdog.feed(arrival.mono_ns)
        self.last_command = commands
        info = CommandInfo(commands.seq, commands.t_capture_ns, commands.face)
        deadline = verdict.capture_deadline_ns
        move = Move("command", positions, info, t_ns=arrival.mono_ns, deadline_ns=deadline)
        self._pending = (move, before)
        return move, verdict

    def hand_over(self, move: Move, wall_ns: int) -> None:
        """The last check of ``move`` (the last :meth:`command`'s) as it goes to the driver, at
        ``wall_ns`` (the controller's wall clock now): a command whose capture is older than
        the limit by now is withdrawn (the core is as it was before the command: the face
        holds, the watchdog counts from the last command handed over) and
        :class:`StaleCapture` is raised, its note set on the first of a run of them."""
        pending, self._pending = self._pending, None
        deadline = move.deadline_ns
        if deadline is None or wall_ns <= deadline:
            if move.command:
                self._late_run = 0
            return
        if pending is None or pending[0] is not move:
            raise RuntimeError("only the last command's move can be withdrawn at its hand-over")
        pending[1].restore(self)
        self.late += 1
        self._late_run += 1
        limit_s = self.freshness.max_age_ns / 1e9
        age_s = limit_s + (wall_ns - deadline) / 1e9
        frame = move.info.frame
        note = ""
        if self._late_run == 1:
            note = (
                f"frame {frame}'s command was {age_s:.3f} s from capture when its turn at the "
                f"driver came (limit {limit_s:g} s): not executed, nor any this late until one "
                "is in time (a loaded machine?)"
            )
        raise StaleCapture(
            f"the command of frame {frame} was {age_s:.3f} s from capture at the hand-over to "
            f"the driver (limit {limit_s:g} s)",
            note,
        )

    # --- moves of its own ---------------------------------------------------------------------

    def due_ns(self) -> int:
        """When :meth:`tick` next has something to do (monotonic ns)."""
        candidates = [self._report_due()]
        if self._ramp is not None and (ramp := self._ramp.due_ns()) is not None:
            candidates.append(ramp)
        elif self._chasing():
            candidates.append(self._step_origin(0) + round(MAX_STEP_S * 1e9))
        if self.mode == "follow" and (watchdog := self.watchdog.due_ns()) is not None:
            candidates.append(watchdog)
        return min(candidates)

    def tick(self, now_ns: int) -> Move | None:
        """The move due at ``now_ns``, if any (call at :meth:`due_ns`, or whenever)."""
        if self.mode == "follow" and self.watchdog.expired(now_ns):
            self._begin_ramp("return", now_ns)
        kind: MoveKind = "stop" if self.mode == "stop" else "return"
        ramp = self._ramp
        if ramp is not None and (due := ramp.due_ns()) is not None:
            if now_ns < due:
                return self._report(now_ns)
            self.targets = ramp.step(self.neutral_positions)
            return self._own_step(kind, now_ns)
        if self._chasing():
            if now_ns < self._step_origin(now_ns) + round(MAX_STEP_S * 1e9):
                return self._report(now_ns)
            return self._own_step(kind if self._ramp is not None else "catch-up", now_ns)
        if self._ramp is not None and self.mode == "return":  # back at neutral: idle
            self.mode, self._ramp = "idle", None
            self.motion.catch_up()
        return self._report(now_ns)

    def stop(self, now_ns: int) -> None:
        """Begin the return to neutral of a shutdown; :attr:`stopped` once it is there."""
        self._begin_ramp("stop", now_ns)

    @property
    def stopped(self) -> bool:
        """Whether a shutdown has brought the face to neutral."""
        return (
            self.mode == "stop"
            and self._ramp is not None
            and self._ramp.due_ns() is None
            and (self.motion.reached(self.neutral_positions))
        )

    def stop_budget_s(self) -> float:
        """Longest a shutdown's return to neutral can take from anywhere (seconds, generous)."""
        slowest = 0.0
        for spec in self.profile.servos:
            travel = spec.max_us - spec.min_us
            seconds = 0.0
            if spec.max_speed > 0:
                seconds += travel / spec.max_speed
            if spec.max_accel > 0:
                seconds += 2 * math.sqrt(travel / spec.max_accel)
                seconds += spec.max_speed / spec.max_accel
            slowest = max(slowest, seconds)
        return self.ramp_s + slowest + 4 * MAX_STEP_S

    # --- internals ----------------------------------------------------------------------------

    def _begin_ramp(self, mode: Literal["return", "stop"], now_ns: int) -> None:
        self.mode = mode
        self._ramp = Ramp.begin(now_ns, self.ramp_s, self.positions)

    def _chasing(self) -> bool:
        """Whether a servo is short of its target and the controller steps it on its own
        (always in real time; in media time only while returning to neutral)."""
        if self.motion.reached(self.targets):
            return False
        return self.motion_time == "real" or self.mode in ("return", "stop")

    def _step_origin(self, now_ns: int) -> int:
        return self._last_step_ns if self._last_step_ns is not None else now_ns

    def _own_step(self, kind: MoveKind, now_ns: int) -> Move:
        dt_ns = now_ns - self._step_origin(now_ns)
        positions = self.motion.step(self.targets, dt_ns / 1e9)
        self._last_step_ns = self._last_report_ns = now_ns
        return Move(kind, positions, t_ns=now_ns)

    def _report_due(self) -> int:
        last = self._last_report_ns if self._last_report_ns is not None else 0
        return last + self.report_ns

    def _report(self, now_ns: int) -> Move | None:
        if now_ns < self._report_due():
            return None
        self._last_report_ns = now_ns
        return Move("report", self.positions, send=False, t_ns=now_ns)
