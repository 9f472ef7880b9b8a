"""The babbler, pure core: plan, pacing, settling and the face-lost pause, with time as data.

The shell feeds it what the bus says (:meth:`Babbler.servos` for ``…/servo_state``,
:meth:`Babbler.features` for ``…/features``) and asks it, as often as it likes,
:meth:`Babbler.step` with the monotonic clock's reading: the answer is where the servos should
be commanded now (paced: no servo is asked to move faster than ``pace`` of its profile speed,
on top of the control interface's own limits) and, when a pose has just settled, the sample to
publish. Phases:

* ``homing``: to neutral, held ``hold_s`` once there; then ``neutral``: the features node
  learns the robot's neutral face (the shell starts it when :attr:`Babbler.at_neutral` turns
  true) until its features say ``neutral_ready``;
* ``babbling``: pose after pose of the plan (:class:`~facesynth.app.learn.plan.BabblePlan`)
  from ``start`` (a resumed session continues its plan); each pose's settled face is told to
  the plan (:meth:`~facesynth.app.learn.plan.BabblePlan.seen`; an adaptive plan chooses its
  next poses from them) before the next pose is asked for, a skipped pose with no face;
* ``paused``: no face for ``face_lost_s``: back to neutral, the pose in progress dropped,
  until a face is seen for ``face_back_s``; then the same pose again (after
  ``max_face_retries`` losses on one pose it is skipped);
* ``streaming`` (with ``stream``, from its ``start`` pose of the plan on, e.g. after the
  sweeps): no more settled poses; the servos follow the stream's trajectory
  (:class:`~facesynth.app.learn.stream.Trajectory`, paced as poses are) and every frame with a
  face becomes a :class:`StreamFrame`, its features with the command in force when it was
  taken; every ``neutral_every_s`` a settled neutral pose, as the plans take one every few
  poses (the fit measures the camera's noise and the neutral's drift on them); a lost face
  pauses it as it pauses poses;
* ``finishing`` → ``done``: the budget is spent (poses or time): back to neutral.
"""

from __future__ import annotations

import collections
from collections.abc import Mapping
from dataclasses import dataclass, field

from facesynth.app.learn.plan import BabblePlan, Pose, to_pulses
from facesynth.app.learn.settle import Settle, Settled, SettleOptions, StalledError, near
from facesynth.app.learn.stream import HISTORY_S, StreamFrame, Streaming
from facesynth.runtime.profiles import Profile, ServoSpec

#: Pace of a servo whose profile sets no ``max_speed`` (µs/s).
DEFAULT_SPEED_US_S = 2000.0


def paced_speed(servo: ServoSpec, pace: float) -> float:
    """How fast babbling moves ``servo`` (µs/s): ``pace`` of its profile's ``max_speed``, or of
    :data:`DEFAULT_SPEED_US_S` where the profile sets none."""
    return pace * (servo.max_speed if servo.max_speed > 0 else DEFAULT_SPEED_US_S)


class BabbleError(ValueError):
    """Babbling options that cannot be used."""


@dataclass(frozen=True)
class BabbleOptions:
    """How the babbler moves and waits."""

    settle: SettleOptions = field(default_factory=SettleOptions)
    pace: float = 0.8
    hold_s: float = 0.5
    face_lost_s: float = 1.0
    face_back_s: float = 0.5
    max_face_retries: int = 2

    def __post_init__(self) -> None:
        if not 0 < self.pace <= 1:
            raise BabbleError(f"the pace is a fraction of the profile's speeds, not {self.pace}")
        if self.hold_s < 0 or not self.face_lost_s > 0 or self.face_back_s < 0:
            raise BabbleError("the hold and face waits must not be negative")


@dataclass(frozen=True)
class Budget:
    """When babbling ends: after pose ``poses`` of the plan (the session's total), or at the
    monotonic instant ``until_ns`` (whichever first; ``None``: no bound)."""

    poses: int | None = None
    until_ns: int | None = None


@dataclass(frozen=True)
class Sample:
    """A settled pose, ready to publish."""

    pose: Pose
    commanded: dict[str, float]
    reported: dict[str, float]
    face: Settled
    t_ns: int
    #: Where the servos read themselves back when the pose settled (empty: not read back).
    measured: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Step:
    """What the shell does now: command ``targets``; publish ``sample`` if there is one, and
    the stream's ``frames`` taken since the last step."""

    targets: dict[str, float]
    phase: str
    sample: Sample | None = None
    frames: tuple[StreamFrame, ...] = ()


class Babbler:
    """See the module docstring."""

    def __init__(
        self,
        profile: Profile,
        plan: BabblePlan,
        *,
        start: int = 0,
        budget: Budget | None = None,
        options: BabbleOptions | None = None,
        stream: Streaming | None = None,
    ) -> None:
        servos = len(plan.pose(0).u)
        if servos != len(profile.servos):
            raise BabbleError(
                f"a plan for {servos} servos cannot drive profile {profile.name!r} "
                f"({len(profile.servos)} servos)"
            )
        self.profile = profile
        self.plan = plan
        self.options = options or BabbleOptions()
        self.budget = budget or Budget()
        self.stream = stream
        self._tol = self.options.settle.reach_tol_us
        self.neutral = profile.neutral_positions()
        self.speeds = {s.name: paced_speed(s, self.options.pace) for s in profile.servos}
        self.phase = "homing"
        self.index = start
        #: Poses taken in this run, and poses skipped (face lost too often).
        self.taken = 0
        self.skipped = 0
        #: Frames taken while streaming, in this run.
        self.streamed = 0
        self.at_neutral = False
        self.commanded = dict(self.neutral)
        self.reported: dict[str, float] | None = None
        #: The servos' read-back positions in C's last report (empty: the driver reads none).
        self.measured: dict[str, float] = {}
        #: Poses taken, by how the servos were known to be there (Settled.reached).
        self.reached: collections.Counter[str] = collections.Counter()
        self._goal = dict(self.neutral)
        self._last_ns: int | None = None
        self._reached_ns: int | None = None
        self._settle: Settle | None = None
        self._pose: Pose | None = None
        self._neutral_ready = False
        self._last_face_ns: int | None = None
        self._face_since_ns: int | None = None
        self._retries = 0
        self._stopping = False
        self._homing_ns: int | None = None
        self._finishing_ns: int | None = None
        self._stream_ns: int | None = None
        self._neutral_ns: int | None = None
        self._sent: collections.deque[tuple[int, dict[str, float]]] = collections.deque()
        self._frames: list[StreamFrame] = []

    # --- what the bus says -------------------------------------------------------------------

    def servos(
        self,
        positions: Mapping[str, float],
        now_ns: int,
        measured: Mapping[str, float] | None = None,
    ) -> None:
        """Where the control interface reports the servos (``…/servo_state``): commanded, and
        ``measured`` where its driver reads them back (poses then settle on those)."""
        self.reported = dict(positions)
        self.measured = dict(measured or {})
        if self._settle is not None:
            self._settle.servos(positions, now_ns, self.measured)
        if self._reached_ns is None and near(positions, self._goal, self._tol):
            self._reached_ns = now_ns

    def features(
        self,
        face: bool,
        raw: Mapping[str, float],
        neutral_ready: bool,
        now_ns: int,
        arrived_ns: int | None = None,
    ) -> None:
        """One ``…/features`` message (only once the features node runs); ``now_ns`` is when
        its frame was taken, on the same monotonic clock (a pose is judged from frames taken
        after it was reached), ``arrived_ns`` when the message came (default ``now_ns``: the
        face-lost pause runs on arrivals, so a loaded chain's latency is not a lost face)."""
        if not face:
            self._face_since_ns = None
            return
        arrived = now_ns if arrived_ns is None else arrived_ns
        self._last_face_ns = arrived
        if self._face_since_ns is None:
            self._face_since_ns = arrived
        self._neutral_ready = self._neutral_ready or neutral_ready
        if self._settle is not None and self.phase == "babbling" and raw:
            self._settle.face(raw, now_ns)
        if self.phase == "streaming" and raw:
            self._stream_frame(dict(raw), now_ns)

    @property
    def face_seen(self) -> bool:
        """Whether the features have shown a face yet."""
        return self._last_face_ns is not None

    def stop(self) -> None:
        """End babbling now (Ctrl-C): back to neutral, then ``done``."""
        self._stopping = True

    # --- what to do -------------------------------------------------------------------------

    @property
    def done(self) -> bool:
        """Whether babbling is over and the servos are back at neutral."""
        return self.phase == "done"

    def step(self, now_ns: int) -> Step:
        """Where to command the servos now, and the pose that settled, if one did."""
        sample = None
        timeout_ns = self.options.settle.reach_timeout_s * 1e9
        if self._stopping or self._spent(now_ns):
            if self.phase not in ("finishing", "done"):
                self.phase = "finishing"
                self._finishing_ns = now_ns
                self._go(self.neutral)
            if self.phase == "finishing":
                started = self._finishing_ns if self._finishing_ns is not None else now_ns
                # without reports the servos are left to the controller's own return
                if self._holding(now_ns, 0.0) or now_ns - started > timeout_ns:
                    self.phase = "done"
        elif self.phase == "homing":
            if self._homing_ns is None:
                self._homing_ns = now_ns
            if self._holding(now_ns, self.options.hold_s):
                self.phase = "neutral"
                self.at_neutral = True
            elif self._reached_ns is None and now_ns - self._homing_ns > timeout_ns:
                raise StalledError(
                    f"the servos were not reported at neutral within "
                    f"{self.options.settle.reach_timeout_s:g} s"
                )
        elif self.phase == "neutral":
            if self._neutral_ready:
                self.phase = "babbling"
                self._begin_pose(now_ns)
        elif self.phase == "babbling":
            if self._face_lost(now_ns):
                self._pause()
            else:
                sample = self._babble(now_ns)
        elif self.phase == "streaming":
            if self._face_lost(now_ns):
                self._pause()
            else:
                self._streaming(now_ns)
        elif self.phase == "paused":
            since = self._face_since_ns
            if since is not None and now_ns - since >= self.options.face_back_s * 1e9:
                self.phase = "babbling"
                self._begin_pose(now_ns)
        frames, self._frames = tuple(self._frames), []
        return Step(self._paced(now_ns), self.phase, sample, frames)

    def _babble(self, now_ns: int) -> Sample | None:
        settle, pose = self._settle, self._pose
        if settle is None or pose is None:
            self._begin_pose(now_ns)
            return None
        if self.commanded != self._goal:  # still pacing there: the reach timeout starts after
            settle.commanded_ns = now_ns
            return None
        face = settle.check(now_ns)
        if face is None:
            return None
        sample = Sample(
            pose, dict(settle.target), dict(self.reported or {}), face, now_ns, dict(self.measured)
        )
        self.reached[face.reached] += 1
        self.plan.seen(pose, face.features)
        self.taken += 1
        self.index += 1
        self._retries = 0
        self._begin_pose(now_ns)
        return sample

    def _begin_pose(self, now_ns: int) -> None:
        self._settle = self._pose = None
        if self._spent(now_ns):
            return
        if self.stream is not None and self.index >= self.stream.start:
            self.phase = "streaming"
            self._streaming(now_ns)
            return
        self._settle_at(self.plan.pose(self.index), now_ns)

    def _settle_at(self, pose: Pose, now_ns: int) -> None:
        target = to_pulses(self.profile, pose.u)
        self._pose = pose
        self._go(target)
        self._settle = Settle(target, now_ns, self.options.settle)
        if self.reported is not None:
            self._settle.servos(self.reported, now_ns, self.measured)

    def _pause(self) -> None:
        streaming = self.phase == "streaming"
        self.phase = "paused"
        self._face_since_ns = None
        self._retries += 0 if streaming else 1  # a stream has no pose to give up on
        if self._retries > self.options.max_face_retries:
            self.plan.seen(self.plan.pose(self.index), {})
            self.skipped += 1
            self.index += 1
            self._retries = 0
        self._settle = self._pose = None
        self._go(self.neutral)

    def _streaming(self, now_ns: int) -> None:
        """Head for where the trajectory is now (paced like any goal)."""
        stream = self.stream
        assert stream is not None
        if self._stream_ns is None:
            self._stream_ns = self._neutral_ns = now_ns
        if (
            self._neutral_ns is not None
            and now_ns - self._neutral_ns >= stream.neutral_every_s * 1e9
        ):
            self._neutral_ns = now_ns
            self.phase = "babbling"  # one settled neutral, then the stream again
            self._settle_at(Pose(self.index, "neutral", (0.0,) * len(self.neutral)), now_ns)
            return
        t_s = stream.offset_s + (now_ns - self._stream_ns) / 1e9
        self._go(to_pulses(self.profile, stream.trajectory.at(t_s)))

    def _stream_frame(self, raw: dict[str, float], frame_ns: int) -> None:
        """A frame taken at ``frame_ns`` while streaming, with the command then in force
        (none known: a frame from before the stream began, left out)."""
        commanded = None
        for sent_ns, command in reversed(self._sent):
            if sent_ns <= frame_ns:
                commanded = command
                break
        if commanded is not None:
            self._frames.append(StreamFrame(frame_ns, commanded, raw))
            self.streamed += 1

    def _face_lost(self, now_ns: int) -> bool:
        last = self._last_face_ns
        return last is None or now_ns - last > self.options.face_lost_s * 1e9

    def _spent(self, now_ns: int) -> bool:
        budget = self.budget
        if budget.until_ns is not None and now_ns >= budget.until_ns:
            return True
        return budget.poses is not None and self.index >= budget.poses

    def _go(self, goal: Mapping[str, float]) -> None:
        self._goal = dict(goal)
        self._reached_ns = None
        if self.reported is not None and near(self.reported, self._goal, self._tol):
            self._reached_ns = self._last_ns

    def _holding(self, now_ns: int, seconds: float) -> bool:
        """Whether the servos are reported at the goal, commanded there, for ``seconds``."""
        if self.commanded != self._goal or self._reached_ns is None:
            return False
        return now_ns - self._reached_ns >= seconds * 1e9

    def _paced(self, now_ns: int) -> dict[str, float]:
        """The command moved toward the goal, no servo faster than its pace."""
        dt = 0.0 if self._last_ns is None else max(0.0, (now_ns - self._last_ns) / 1e9)
        self._last_ns = now_ns
        for name, goal in self._goal.items():
            now = self.commanded[name]
            room = self.speeds[name] * dt
            self.commanded[name] = (
                goal if abs(goal - now) <= room else now + room * (1 if goal > now else -1)
            )
        if self.phase == "streaming":  # what was in force when each frame was taken
            self._sent.append((now_ns, dict(self.commanded)))
            while self._sent and self._sent[0][0] < now_ns - HISTORY_S * 1e9:
                self._sent.popleft()
        else:
            self._sent.clear()
        return dict(self.commanded)
