"""``facesynth bench robot``: how much a head driven by a profile moves like the performer.

In process, for simulated heads, faster than real time and deterministic (time is data):

* the performer: every frame of the video → the tracker (``full`` model, blendshapes on) → F
  (its neutral: the first second with a face), once (:func:`track_performer`), shared by every
  profile and head;
* the robot (:class:`RobotLoop`, one per profile and head): each performer frame's features →
  T (the profile) → C (T and C as the stepped chain runs them,
  :class:`facesynth.app.engine.stepped.RobotCores`; C on the robot's own clock:
  checks, clamping, ``max_speed``/``max_accel``, and its own catch-up steps every
  ``MAX_STEP_S`` between commands, as the control service runs them) → each servo's channel on
  the head (``command(channel, pulse_us)``, the head's own dynamics stepped to each move's
  instant) → the head's camera image at the frame's instant → the same tracker and F. The
  robot's neutral is learned first, while C holds the head at the profile's neutral
  (:data:`SETTLE_S` to settle, then F's neutral window);
* both sides' ``Features.raw`` (relative to each face's neutral, unscaled) are aligned per
  frame and compared by :mod:`.robot_compare`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Final, Protocol

import numpy as np

from facesynth.app.engine.stepped import RobotCores, SteppedChain, sensor_frame
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.schemas.messages import Features, Points
from facesynth.services.control.core import Move
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig
from facesynth.services.sensor.sources.video import VideoConfig, VideoSource

from .robot_compare import (
    FeatureRow,
    FeatureStream,
    Summary,
    best_lag,
    compare,
    mark_reach,
    summarize,
)

__all__ = [
    "DEFAULT_PROFILES",
    "Head",
    "HeadRun",
    "Performance",
    "ProfileRun",
    "RobotBench",
    "RobotError",
    "RobotLoop",
    "bench_robot",
    "measure",
    "robot_features",
    "track_performer",
]

#: The hand-written profiles measured when none is named.
DEFAULT_PROFILES: Final = ("paper16", "head16", "head16_bs")
#: Tracker model watching both faces.
MODEL: Final = "full"
#: F's neutral window on both faces (seconds with a face).
NEUTRAL_S: Final = 1.0
#: Seconds the head is held at neutral before its neutral is measured (the head settles from
#: its rest, the tracker's crop settles).
SETTLE_S: Final = 1.0
#: Seconds after which a head at neutral without a face (or a neutral) is an error.
NEUTRAL_TIMEOUT_S: Final = 5.0


class RobotError(ValueError):
    """A head, profile or video ``bench robot`` cannot measure; one line."""


class Head(Protocol):
    """What the bench needs of a simulated head (:class:`facesynth.app.simhead.SimHead`)."""

    def command(self, channel: int, pulse_us: float) -> None:
        """Set a channel's target pulse (µs)."""

    def step(self, t_ns: int) -> None:
        """Advance the actuators' dynamics to ``t_ns``."""

    def render(self) -> np.ndarray:
        """The head's camera image now (BGR)."""


def tracker(model: str = MODEL) -> TrackerBackend:
    """The tracker both faces are watched with (LiteRT when installed, blendshapes on)."""
    return TrackerBackend(TrackerConfig(model=model))


@dataclass(frozen=True)
class Performance:
    """The performer's side, tracked once: F's output per frame and its raw stream."""

    video: str
    fps: float
    features: list[Features]
    stream: FeatureStream
    seconds: float


def robot_features(features: Features) -> dict[str, float] | None:
    """The raw values of one frame (``None`` without a face or before the neutral is known)."""
    if not features.face or not features.neutral_ready or not features.raw:
        return None
    return features.raw


def track_performer(
    video: str, *, frames: int | None = None, model: str = MODEL, start: int = 0
) -> Performance:
    """The performer's features from ``frames`` frames of ``video`` (all: None) from frame
    ``start`` on; a segment plays as a video of its own (media time from 0 at ``start``, F's
    neutral from its first second)."""
    if frames is not None and frames < 1:
        raise RobotError("--frames must be at least 1")
    if start < 0:
        raise RobotError("the first frame must be 0 or later")
    started = time.monotonic()
    source = VideoSource(VideoConfig(path=video))
    chain = SteppedChain(tracker(model), FeatureProcessor(neutral_seconds=NEUTRAL_S))
    out: list[Features] = []
    origin_ns: int | None = None
    try:
        for index, (image, media_ns) in enumerate(source.frames()):
            seq = index - start
            if seq < 0:
                continue
            if frames is not None and seq >= frames:
                break
            if image is None:  # pragma: no cover - a video file always has pixels
                raise RobotError(f"{video}: a frame without pixels")
            origin_ns = media_ns if origin_ns is None else origin_ns
            t_media_ns = media_ns - origin_ns
            frame = sensor_frame(image, seq, t_media_ns, t_capture_ns=t_media_ns)
            step = chain.step(frame)
            assert step.features is not None
            out.append(step.features)
    finally:
        source.close()
    if not any(robot_features(f) for f in out):
        raise RobotError(f"{video}: the tracker never found the performer's face with a neutral")
    stream = FeatureStream.from_frames([robot_features(f) for f in out])
    return Performance(video, source.info.fps, out, stream, time.monotonic() - started)


class RobotLoop:
    """One profile driving one head in process: T → C → the head → its camera → tracker → F.

    Time is data: the robot's clock starts at 0 when C starts; :meth:`start` holds the head at
    neutral until F knows the robot's neutral, and each performer frame then plays at that
    instant plus its media time (:meth:`step`)."""

    def __init__(
        self,
        profile: Profile,
        head: Head,
        *,
        fps: float,
        backend: PointsBackend | None = None,
        settle_s: float = SETTLE_S,
        calibration: Calibration | None = None,
    ) -> None:
        if not fps > 0:
            raise RobotError("the frame rate must be positive")
        self.profile = profile
        self.head = head
        #: T and C as the stepped chain runs them (C on the robot's clock, in real time).
        self.cores = RobotCores.of_profile("robot", profile, calibration=calibration)
        self.translator = self.cores.translator
        self.control = self.cores.control
        self.channels = {spec.name: spec.channel for spec in profile.servos}
        self.backend = backend if backend is not None else tracker()
        self.processor = FeatureProcessor(neutral_seconds=NEUTRAL_S, neutral_held=True)
        self.period_ns = round(1e9 / fps)
        self.settle_ns = round(settle_s * 1e9)
        self.now_ns = 0
        self.seq = 0
        #: The points the tracker found on the head's last camera image.
        self.points: Points | None = None
        #: The robot's clock at the performer's media time 0 (known after :meth:`start`).
        self.origin_ns: int | None = None

    def start(self) -> Features:
        """Hold the head at the profile's neutral until F has learned the robot's neutral;
        the last frame's features (raise :class:`RobotError` if no face is seen)."""
        self._send(self.cores.start(0))
        limit = self.settle_ns + round(NEUTRAL_TIMEOUT_S * 1e9)
        while self.now_ns <= limit:
            self.now_ns += self.period_ns
            self._advance(self.now_ns)
            self.head.step(self.now_ns)
            points = self._points(self.head.render())
            if self.now_ns < self.settle_ns:
                continue  # the head and the tracker's crop settle; F does not see it yet
            features = self.processor.process(points)
            if robot_features(features) is not None:
                self.origin_ns = self.now_ns + self.period_ns
                return features
        raise RobotError(
            f"the tracker found no face (or no neutral) on the head held at "
            f"{self.profile.name}'s neutral within {limit / 1e9:.0f} s"
        )

    def step(self, performer: Features) -> tuple[np.ndarray, Features]:
        """Play one performer frame: the head's camera image and the robot's features."""
        if self.origin_ns is None:
            self.start()
        assert self.origin_ns is not None
        t_ns = max(self.now_ns, self.origin_ns + performer.t_media_ns)
        self._advance(t_ns)
        _, move = self.cores.command(performer, t_ns)
        self._send(move)
        self.now_ns = t_ns
        self.head.step(t_ns)
        image = self.head.render()
        return image, self._look(image)

    def _advance(self, t_ns: int) -> None:
        """C's own moves (catch-up steps, returns) due up to ``t_ns``, sent as they happen."""
        for move in self.cores.advance(t_ns):
            self._send(move)

    def _send(self, move: Move) -> None:
        self.head.step(move.t_ns)
        for name, pulse in move.positions.items():
            try:
                self.head.command(self.channels[name], pulse)
            except ValueError as exc:  # e.g. a channel the head does not have
                raise RobotError(f"profile {self.profile.name}, servo {name}: {exc}") from None

    def _points(self, image: np.ndarray) -> Points:
        frame = sensor_frame(image, self.seq, self.now_ns, t_capture_ns=self.now_ns)
        self.seq += 1
        self.points = self.backend.process(frame)
        return self.points

    def _look(self, image: np.ndarray) -> Features:
        return self.processor.process(self._points(image))


@dataclass(frozen=True)
class ProfileRun:
    """One profile on one head: per feature rows (reach marked across the head's profiles),
    the summary, the lag (frames) at which the robot follows best with the mean ρ over the
    moved features there, and the seconds it took."""

    profile: str
    rows: list[FeatureRow]
    summary: Summary
    seconds: float
    lag_frames: int = 0
    lag_rho: float = float("nan")


@dataclass(frozen=True)
class HeadRun:
    """Every profile on one head."""

    head: str
    profiles: list[ProfileRun]


@dataclass(frozen=True)
class RobotBench:
    """The whole benchmark: the performer's video and every head."""

    video: str
    frames: int
    fps: float
    model: str
    performer_seconds: float
    heads: list[HeadRun] = field(default_factory=list)


def run_profile(
    performance: Performance,
    profile: Profile,
    head: Head,
    *,
    on_frame: Callable[[int, np.ndarray, Features], None] | None = None,
) -> FeatureStream:
    """The robot's raw features for every performer frame (``on_frame`` sees each image)."""
    loop = RobotLoop(profile, head, fps=performance.fps)
    loop.start()
    frames: list[dict[str, float] | None] = []
    for index, performer in enumerate(performance.features):
        image, features = loop.step(performer)
        frames.append(robot_features(features))
        if on_frame is not None:
            on_frame(index, image, features)
    return FeatureStream.from_frames(frames, names=performance.stream.names)


def bench_robot(
    performance: Performance,
    heads: Iterable[str],
    profiles: Sequence[str],
    open_head: Callable[[str], Head],
    *,
    progress: Callable[[str], None] | None = None,
) -> RobotBench:
    """Every profile on every simulated head, in process (``open_head(name)`` builds a fresh
    head per run)."""

    def run(head: str, profile: Profile) -> FeatureStream:
        return run_profile(performance, profile, open_head(head))

    return measure(performance, heads, profiles, run, progress=progress)


def measure(
    performance: Performance,
    heads: Iterable[str],
    profiles: Sequence[str | Profile],
    run: Callable[[str, Profile], FeatureStream],
    *,
    progress: Callable[[str], None] | None = None,
) -> RobotBench:
    """Every profile on every head, each run by ``run(head, profile)`` (the robot's stream),
    compared with the performer's; reach marked per head (a profile: by name, or loaded)."""
    loaded = [p if isinstance(p, Profile) else _load(p) for p in profiles]
    result = RobotBench(
        video=performance.video,
        frames=len(performance.features),
        fps=performance.fps,
        model=MODEL,
        performer_seconds=round(performance.seconds, 2),
    )
    for head_name in heads:
        runs: list[list[FeatureRow]] = []
        seconds: list[float] = []
        lags: list[tuple[int, float]] = []
        for profile in loaded:
            if progress is not None:
                progress(f"{head_name} / {profile.name}")
            started = time.monotonic()
            robot = run(head_name, profile)
            runs.append(compare(performance.stream, robot))
            lags.append(best_lag(performance.stream, robot))
            seconds.append(time.monotonic() - started)
        marked = mark_reach(runs)
        result.heads.append(
            HeadRun(
                head_name,
                [
                    ProfileRun(profile.name, rows, summarize(rows), round(s, 2), *lag)
                    for profile, rows, s, lag in zip(loaded, marked, seconds, lags, strict=True)
                ],
            )
        )
    return result


def _load(name: str) -> Profile:
    try:
        return load_profile(name)
    except ValueError as exc:
        raise RobotError(str(exc)) from None
