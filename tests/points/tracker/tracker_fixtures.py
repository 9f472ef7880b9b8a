"""Paths and the tracked-video record shared by the face-tracker tests."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from facesynth.services.points.tracker import FaceTracker, TrackResult
from facesynth.services.points.tracker.offline import iter_video_frames

REPO = Path(__file__).resolve().parents[3]
VIDEO = REPO / "facesynth" / "app" / "data" / "WolfgangLanger_Pexels.mp4"
OPENFACE_CSV = REPO / "facesynth" / "app" / "data" / "OpenFace_Test.csv"
VIDEO_FRAMES = 472
SAMPLE_EVERY = 40


@dataclass
class TrackedVideo:
    """The sample video tracked once with the default (LiteRT) backend."""

    results: list[TrackResult]
    samples: dict[int, np.ndarray]  # frame index -> BGR frame, every SAMPLE_EVERY frames

    @property
    def meshes(self) -> np.ndarray:
        """(frames, 468, 3) for frames with a face."""
        return np.stack([r.mesh for r in self.results if r.mesh is not None])

    @property
    def ibug(self) -> np.ndarray:
        """(frames, 68, 2) for frames with a face."""
        return np.stack([r.ibug68 for r in self.results if r.ibug68 is not None])


class TrackedByModel:
    """The sample video tracked once per tracker model (LiteRT), on first request."""

    def __init__(self) -> None:
        self._done: dict[str, TrackedVideo] = {}

    def __getitem__(self, model: str) -> TrackedVideo:
        if model not in self._done:
            tracker = FaceTracker(backend="litert", model=model)
            results: list[TrackResult] = []
            samples: dict[int, np.ndarray] = {}
            for i, frame in enumerate(iter_video_frames(VIDEO)):
                results.append(tracker.process(frame))
                if i % SAMPLE_EVERY == 0:
                    samples[i] = frame
            self._done[model] = TrackedVideo(results, samples)
        return self._done[model]
