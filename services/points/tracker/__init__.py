"""facesynth face-tracker engine (pure: no asyncio, no network).

MediaPipe's BlazeFace detector, 468-point face mesh and iris models, run with ai-edge-litert or
OpenCV DNN, plus the 68-point iBUG view of the mesh, and offline video tracking.

Typical use::

    from services.points.tracker import FaceTracker

    tracker = FaceTracker()
    result = tracker.process(frame_bgr)
    if result.face:
        points68 = result.ibug68
"""

from __future__ import annotations

from .errors import ModelError, VideoError
from .ibug68 import mesh_to_ibug68
from .inference import available_backends
from .offline import track_video
from .tracker import FaceTracker, TrackResult

__all__ = [
    "FaceTracker",
    "ModelError",
    "TrackResult",
    "VideoError",
    "available_backends",
    "mesh_to_ibug68",
    "track_video",
]
