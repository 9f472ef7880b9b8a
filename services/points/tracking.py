"""The face tracker as a point streamer backend (P's default).

Decodes each frame, runs :class:`services.points.tracker.FaceTracker` and publishes three point
sets: ``ibug68`` (the paper's 68 points, derived from the mesh), ``mesh468`` (x, y, z) and
``iris10``. A frame without a face gives "no face", never the previous frame's points.
"""

from __future__ import annotations

from facesynth.runtime.frames import decode_frame
from facesynth.runtime.landmarks import IBUG68, IRIS10, MESH468
from schemas.messages import Frame, Points
from services.points.backends import BackendError, PointsBackend, face_points, no_face, point_set


class TrackerBackend(PointsBackend):
    """Live face tracking on the frames' pixels."""

    name = "tracker"

    def __init__(
        self,
        backend: str = "auto",
        *,
        redetect_every: int = 30,
        select: str = "largest",
        num_threads: int = 1,
    ) -> None:
        from services.points.tracker import FaceTracker

        self.tracker = FaceTracker(
            backend=backend, redetect_every=redetect_every, select=select, num_threads=num_threads
        )

    def needs_pixels(self) -> bool:
        return True

    def process(self, frame: Frame) -> Points:
        if frame.encoding == "none":
            raise BackendError(f"frame {frame.seq} has no pixels: the tracker needs images")
        result = self.tracker.process(decode_frame(frame))
        if not result.face or result.ibug68 is None or result.mesh is None:
            return no_face(frame, self.name, result.presence)
        sets = [point_set(IBUG68, result.ibug68), point_set(MESH468, result.mesh)]
        if result.iris is not None:
            sets.append(point_set(IRIS10, result.iris))
        return face_points(frame, sets, result.presence, self.name)
