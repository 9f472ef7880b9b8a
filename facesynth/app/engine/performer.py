"""A performer's video tracked once, in process: every frame → the tracker → F (time is data).

:func:`track_video` gives F's output per frame, as the stepped chain makes it: each frame's
media time from 0 at the first frame played, F's neutral from its first second with a face or
from a performer calibration's neutral step. ``bench robot`` compares a head against it
(:func:`facesynth.app.bench.robot.track_performer`), ``facesynth plan`` plans a robot's
commands for it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from facesynth.app.engine.robot_loop import MODEL, NEUTRAL_S, RobotError, robot_features, tracker
from facesynth.app.engine.stepped import SteppedChain, sensor_frame
from facesynth.runtime.calibration import Calibration
from facesynth.schemas.messages import Features
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.sensor.sources.video import VideoConfig, VideoSource

__all__ = ["TrackedVideo", "track_video"]


@dataclass(frozen=True)
class TrackedVideo:
    """F's output per frame played, the video's frame rate and the seconds tracking took."""

    features: list[Features]
    fps: float
    seconds: float


def track_video(
    video: str,
    *,
    frames: int | None = None,
    model: str = MODEL,
    start: int = 0,
    calibration: Calibration | None = None,
) -> TrackedVideo:
    """The performer's features from ``frames`` frames of ``video`` (all: None) from frame
    ``start`` on; a segment plays as a video of its own (media time from 0 at ``start``, F's
    neutral from its first second, or ``calibration``'s neutral when given).
    :class:`RobotError` for bad bounds, or when the tracker never finds her face with a
    neutral (the video source's own errors for a video it cannot open)."""
    if frames is not None and frames < 1:
        raise RobotError("--frames must be at least 1")
    if start < 0:
        raise RobotError("the first frame must be 0 or later")
    started = time.monotonic()
    source = VideoSource(VideoConfig(path=video))
    processor = (
        FeatureProcessor(neutral_seconds=NEUTRAL_S)
        if calibration is None
        else FeatureProcessor.from_calibration(calibration, neutral_seconds=NEUTRAL_S)
    )
    chain = SteppedChain(tracker(model), processor)
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
    return TrackedVideo(out, source.info.fps, time.monotonic() - started)
