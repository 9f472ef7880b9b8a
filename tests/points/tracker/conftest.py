"""Shared fixtures for the face-tracker tests: the bundled sample video, tracked once."""

from __future__ import annotations

import numpy as np
import pytest
from tracker_fixtures import SAMPLE_EVERY, VIDEO, TrackedByModel, TrackedVideo

from facesynth.services.points.tracker import FaceTracker, TrackResult
from facesynth.services.points.tracker.offline import iter_video_frames


@pytest.fixture(scope="session")
def tracked_video() -> TrackedVideo:
    tracker = FaceTracker(backend="litert")
    results: list[TrackResult] = []
    samples: dict[int, np.ndarray] = {}
    for i, frame in enumerate(iter_video_frames(VIDEO)):
        results.append(tracker.process(frame))
        if i % SAMPLE_EVERY == 0:
            samples[i] = frame
    return TrackedVideo(results, samples)


@pytest.fixture(scope="session")
def tracked_by_model(tracked_video: TrackedVideo) -> TrackedByModel:
    """The sample video tracked with each tracker model (``fast`` reuses ``tracked_video``)."""
    tracked = TrackedByModel()
    tracked._done["fast"] = tracked_video
    return tracked


@pytest.fixture(scope="session")
def litert_tracker() -> FaceTracker:
    return FaceTracker(backend="litert")


@pytest.fixture(scope="session")
def opencv_tracker() -> FaceTracker:
    return FaceTracker(backend="opencv")


@pytest.fixture()
def tracker(litert_tracker: FaceTracker) -> FaceTracker:
    """The shared LiteRT tracker, reset for this test."""
    litert_tracker.reset()
    return litert_tracker
