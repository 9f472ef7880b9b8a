"""``facesynth bench robot``: how much a head driven by a profile moves like the performer.

In process, for simulated heads, faster than real time and deterministic (time is data):

* the performer: every frame of the video → the tracker (``full`` model, blendshapes on) → F
  (its neutral: the first second with a face, or a performer calibration's neutral step, as
  ``run --calibration`` takes it), once (:func:`track_performer`), shared by every profile and
  head;
* the robot (:class:`RobotLoop`, one per profile and head): each performer frame's features →
  T (the profile) → C (T and C as the stepped chain runs them,
  :class:`facesynth.app.engine.stepped.RobotCores`; C on the robot's own clock:
  checks, clamping, ``max_speed``/``max_accel``, and its own catch-up steps every
  ``MAX_STEP_S`` between commands, as the control service runs them) → each servo's channel on
  the head (``command(channel, pulse_us)``, the head's own dynamics stepped to each move's
  instant) → the head's camera image at the frame's instant → the same tracker and F (T with
  the performer's calibration, if any, as ``run`` gives it). The
  robot's neutral is learned first, while C holds the head at the profile's neutral
  (:data:`SETTLE_S` to settle, then F's neutral window);
* both sides' ``Features.raw`` (relative to each face's neutral, unscaled) are aligned per
  frame and compared by :mod:`.robot_compare`; with the robot's reach of a learned profile
  (:func:`reach_box`: the head's first learned profile, the one learned in process first),
  each feature's amplitude is also taken against her change clipped into that reach.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Final

import numpy as np

from facesynth.app.engine.performer import track_video
from facesynth.app.engine.robot_loop import (
    MODEL,
    Head,
    RobotError,
    RobotLoop,
    robot_features,
)
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.runtime.profiles.learned import shown_inputs, unpack
from facesynth.schemas.messages import Features

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
    "performer_neutral",
    "reach_box",
    "robot_features",
    "track_performer",
]

#: The hand-written profiles measured when none is named.
DEFAULT_PROFILES: Final = ("paper16", "head16", "head16_bs")


#: Where the performer's neutral comes from without a calibration.
FIRST_SECOND: Final = "her first second with a face"


@dataclass(frozen=True)
class Performance:
    """The performer's side, tracked once: F's output per frame and its raw stream; the
    calibration her F took (None: her neutral from her first second with a face)."""

    video: str
    fps: float
    features: list[Features]
    stream: FeatureStream
    seconds: float
    calibration: Calibration | None = None


def performer_neutral(calibration: Calibration | None) -> str:
    """Where the performer's neutral comes from, for the report."""
    if calibration is None:
        return FIRST_SECOND
    return f"calibration {calibration.name!r} (its neutral step)"


def track_performer(
    video: str,
    *,
    frames: int | None = None,
    model: str = MODEL,
    start: int = 0,
    calibration: Calibration | None = None,
) -> Performance:
    """The performer's features from ``frames`` frames of ``video`` (all: None) from frame
    ``start`` on; a segment plays as a video of its own (media time from 0 at ``start``, F's
    neutral from its first second, or ``calibration``'s neutral when given)."""
    tracked = track_video(video, frames=frames, model=model, start=start, calibration=calibration)
    stream = FeatureStream.from_frames([robot_features(f) for f in tracked.features])
    return Performance(video, tracked.fps, tracked.features, stream, tracked.seconds, calibration)


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
    """Every profile on one head, and what the robot moved while babbling when a profile was
    learned for it in process (``babbled``; None: not babbled here); ``reach_from``: the
    learned profile whose reach box the rows' ratio in reach is taken against (None: none)."""

    head: str
    profiles: list[ProfileRun]
    babbled: frozenset[str] | None = None
    reach_from: str | None = None


@dataclass(frozen=True)
class RobotBench:
    """The whole benchmark: the performer's video and every head."""

    video: str
    frames: int
    fps: float
    model: str
    performer_seconds: float
    heads: list[HeadRun] = field(default_factory=list)
    #: Where the performer's neutral came from (:func:`performer_neutral`).
    neutral: str = FIRST_SECOND


def run_profile(
    performance: Performance,
    profile: Profile,
    head: Head,
    *,
    on_frame: Callable[[int, np.ndarray, Features], None] | None = None,
) -> FeatureStream:
    """The robot's raw features for every performer frame (``on_frame`` sees each image); T
    with the performer's calibration, if any."""
    loop = RobotLoop(profile, head, fps=performance.fps, calibration=performance.calibration)
    return play(performance, loop, on_frame)


def play(
    performance: Performance,
    loop: RobotLoop,
    on_frame: Callable[[int, np.ndarray, Features], None] | None = None,
) -> FeatureStream:
    """The robot's raw features for every performer frame played through ``loop`` (which
    starts at the first), ``on_frame`` seeing each image."""
    frames: list[dict[str, float] | None] = []
    for index, performer in enumerate(performance.features):
        image, features = loop.step(performer)
        frames.append(robot_features(features))
        if on_frame is not None:
            on_frame(index, image, features)
    return FeatureStream.from_frames(frames, names=performance.stream.names)


def reach_box(profile: Profile) -> dict[str, tuple[float, float]] | None:
    """A learned profile's record of the robot's reach per input (``reach_low`` ..
    ``reach_high``: its babbled face's 1st to 99th percentile, relative to its neutral), for
    the inputs it can show; None for a profile that is not learned."""
    learned = profile.learned
    if learned is None:
        return None
    shown = set(shown_inputs(learned))
    low, high = unpack(learned.reach_low), unpack(learned.reach_high)
    return {
        name: (float(lo), float(hi))
        for name, lo, hi in zip(learned.inputs, low, high, strict=True)
        if name in shown
    }


def bench_robot(
    performance: Performance,
    heads: Iterable[str],
    profiles: Sequence[str],
    open_head: Callable[[str], Head],
    *,
    progress: Callable[[str], None] | None = None,
    learn: Callable[[str], list[Profile]] | None = None,
) -> RobotBench:
    """Every profile on every simulated head, in process (``open_head(name)`` builds a fresh
    head per run; ``learn`` as :func:`measure` takes it)."""

    def run(head: str, profile: Profile) -> FeatureStream:
        return run_profile(performance, profile, open_head(head))

    return measure(performance, heads, profiles, run, progress=progress, learn=learn)


def measure(
    performance: Performance,
    heads: Iterable[str],
    profiles: Sequence[str | Profile],
    run: Callable[[str, Profile], FeatureStream],
    *,
    progress: Callable[[str], None] | None = None,
    learn: Callable[[str], list[Profile]] | None = None,
) -> RobotBench:
    """Every profile on every head, each run by ``run(head, profile)`` (the robot's stream),
    compared with the performer's; reach marked per head (a profile: by name, or loaded).

    ``learn(head)``: profiles learned for that head in process, run after the others; the
    first one's record of what the robot moved while babbling is the head's ``babbled``.
    The head's first learned profile (one learned in process first) gives the robot's reach
    (:func:`reach_box`) each row's ratio in reach is taken against."""
    loaded = [p if isinstance(p, Profile) else load(p) for p in profiles]
    result = RobotBench(
        video=performance.video,
        frames=len(performance.features),
        fps=performance.fps,
        model=MODEL,
        performer_seconds=round(performance.seconds, 2),
        neutral=performer_neutral(performance.calibration),
    )
    for head_name in heads:
        runs: list[list[FeatureRow]] = []
        seconds: list[float] = []
        lags: list[tuple[int, float]] = []
        on_head, babbled = list(loaded), None
        if learn is not None:
            if progress is not None:
                progress(f"{head_name} / babbling and fitting")
            mine = learn(head_name)
            on_head += mine
            babbled = frozenset(shown_inputs(mine[0].learned)) if mine[0].learned else None
        boxed = next((p for p in on_head[len(loaded) :] + loaded if p.learned), None)
        reach = None if boxed is None else reach_box(boxed)
        for profile in on_head:
            if progress is not None:
                progress(f"{head_name} / {profile.name}")
            started = time.monotonic()
            robot = run(head_name, profile)
            runs.append(compare(performance.stream, robot, reach=reach))
            lags.append(best_lag(performance.stream, robot))
            seconds.append(time.monotonic() - started)
        marked = mark_reach(runs)
        result.heads.append(
            HeadRun(
                head_name,
                [
                    ProfileRun(profile.name, rows, summarize(rows), round(s, 2), *lag)
                    for profile, rows, s, lag in zip(on_head, marked, seconds, lags, strict=True)
                ],
                babbled,
                None if boxed is None else boxed.name,
            )
        )
    return result


def load(name: str) -> Profile:
    """The profile ``name`` (a :class:`RobotError` in one line when it does not load)."""
    try:
        return load_profile(name)
    except ValueError as exc:
        raise RobotError(str(exc)) from None
