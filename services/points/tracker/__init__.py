"""facesynth face-tracker engine (pure: no asyncio, no network).

MediaPipe's BlazeFace detector and a tracker model (:mod:`.landmarkers`: ``fast`` = the
468-point face mesh + iris models, ``full`` = Face Landmarker v2 + blendshapes), run with
ai-edge-litert or OpenCV DNN, plus the 68-point iBUG view of the mesh, and offline video
tracking.

Typical use::

    from services.points.tracker import FaceTracker

    tracker = FaceTracker(model="full")
    result = tracker.process(frame_bgr)
    if result.face:
        points68 = result.ibug68

The names below are imported on first use, so that importing the package (e.g. to list the
tracker models for ``--help``) needs neither OpenCV nor an inference runtime.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import ModelError, VideoError

if TYPE_CHECKING:
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

_LAZY = {
    "FaceTracker": ".tracker",
    "TrackResult": ".tracker",
    "available_backends": ".inference",
    "mesh_to_ibug68": ".ibug68",
    "track_video": ".offline",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(module, __name__), name)
