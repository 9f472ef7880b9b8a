"""The face tracker as a point streamer backend (P's default).

Decodes each frame, runs :class:`services.points.tracker.FaceTracker` with the chosen tracker
model and publishes:

* ``fast`` model: ``ibug68`` (the paper's 68 points, derived from the mesh), ``mesh468``
  (x, y, z) and ``iris10``;
* ``full`` model: ``ibug68`` (from the same 468 vertices), ``mesh478`` (x, y, z: the mesh, then
  both irises), ``iris10`` (the same irises as 2D points, so every reader of ``iris10`` keeps
  working) and, unless switched off, the ``blendshapes52`` score set.

A frame without a face gives "no face", never the previous frame's points.
"""

from __future__ import annotations

from facesynth.runtime.blendshapes import BLENDSHAPES52
from facesynth.runtime.frames import decode_frame
from facesynth.runtime.landmarks import IBUG68, IRIS10, MESH468, MESH478
from schemas.messages import Frame, Points, ScoreSet
from services.points.backends import BackendError, PointsBackend, face_points, no_face, point_set


class TrackerBackend(PointsBackend):
    """Live face tracking on the frames' pixels."""

    name = "tracker"

    def __init__(
        self,
        backend: str = "auto",
        *,
        model: str = "fast",
        blendshapes: bool = True,
        redetect_every: int = 30,
        select: str = "largest",
        num_threads: int = 1,
    ) -> None:
        """Args:
        backend: inference backend (``auto``, ``litert``, ``opencv``).
        model: tracker model name (``fast``, ``full``: see ``services.points.tracker.landmarkers``).
        blendshapes: with ``full``, run the blendshape model.
        redetect_every, select, num_threads: see :class:`~services.points.tracker.FaceTracker`.
        """
        from services.points.tracker import FaceTracker
        from services.points.tracker.landmarkers import model_config

        config = model_config(model, blendshapes=blendshapes) if model == "full" else model
        self.tracker = FaceTracker(
            backend=backend,
            redetect_every=redetect_every,
            select=select,
            num_threads=num_threads,
            model=config,
        )

    def needs_pixels(self) -> bool:
        return True

    def process(self, frame: Frame) -> Points:
        if frame.encoding == "none":
            raise BackendError(f"frame {frame.seq} has no pixels: the tracker needs images")
        result = self.tracker.process(decode_frame(frame))
        if not result.face or result.ibug68 is None or result.mesh is None:
            return no_face(frame, self.name, result.presence)
        sets = [point_set(IBUG68, result.ibug68)]
        if result.mesh478 is not None:
            sets.append(point_set(MESH478, result.mesh478))
        else:
            sets.append(point_set(MESH468, result.mesh))
        if result.iris is not None:
            sets.append(point_set(IRIS10, result.iris))
        points = face_points(frame, sets, result.presence, self.name)
        if result.blendshapes is not None:
            values = result.blendshapes.astype(float).tolist()
            points.scores = [ScoreSet(scheme=BLENDSHAPES52, values=values)]
        return points
