"""facesynth face-tracker engine (pure: no asyncio, no network).

MediaPipe's BlazeFace detector, 468-point face mesh and iris models, run by a registered
inference runtime (:mod:`.runtimes`: ai-edge-litert or OpenCV DNN), plus the 68-point iBUG view
of the mesh, and offline video tracking.

Typical use::

    from facesynth.services.points.tracker import FaceTracker

    tracker = FaceTracker()
    result = tracker.process(frame_bgr)
    if result.face:
        points68 = result.ibug68

The names below are imported on first use: importing this package (and :mod:`.runtimes`, whose
names the command line lists) needs no OpenCV, so hosts without it can still list the runtimes.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import ModelError, VideoError

if TYPE_CHECKING:
    from .ibug68 import mesh_to_ibug68
    from .offline import track_video
    from .runtimes import available_backends
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

_MODULES = {
    "FaceTracker": ".tracker",
    "TrackResult": ".tracker",
    "available_backends": ".runtimes",
    "mesh_to_ibug68": ".ibug68",
    "track_video": ".offline",
}


def __getattr__(name: str) -> Any:
    """The engine's classes and functions, imported from their module on first use."""
    module = _MODULES.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value
