"""The bundled sample video tracked once, frame by frame, for the feature tests on real video."""

from __future__ import annotations

import cv2

from facesynth.app.data import sample_video
from facesynth.runtime.frames import encode_frame
from facesynth.schemas.messages import Points
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

#: Frames of the sample video (a face on every one).
SAMPLE_FRAMES = 472


def track_sample(model: str) -> list[Points]:
    """Every frame's points with the tracker ``model``, media time from the video's rate."""
    capture = cv2.VideoCapture(str(sample_video()))
    fps = capture.get(cv2.CAP_PROP_FPS)
    backend = TrackerBackend(TrackerConfig(model=model))
    points: list[Points] = []
    while True:
        ok, image = capture.read()
        if not ok:
            break
        seq = len(points)
        frame = encode_frame(
            image, seq=seq, t_capture_ns=seq, t_media_ns=round(seq * 1e9 / fps), encoding="raw"
        )
        points.append(backend.process(frame))
    capture.release()
    assert len(points) == SAMPLE_FRAMES and all(p.face for p in points)
    return points
