"""The face tracker as a point streamer backend (P's default).

Decodes each frame, runs :class:`services.points.tracker.FaceTracker` and publishes three point
sets: ``ibug68`` (the paper's 68 points, derived from the mesh), ``mesh468`` (x, y, z) and
``iris10``. A frame without a face gives "no face", never the previous frame's points.
"""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec

from facesynth.runtime.frames import decode_frame
from facesynth.runtime.landmarks import IBUG68, IRIS10, MESH468
from schemas.messages import Frame, Points
from services.points.backends.base import (
    BackendError,
    PointsBackend,
    face_points,
    no_face,
    point_set,
)
from services.points.backends.registry import BACKENDS
from services.points.tracker.runtimes import backend_choices, check_backend_name


class TrackerConfig(
    msgspec.Struct, tag="tracker", tag_field="backend", kw_only=True, forbid_unknown_fields=True
):
    """Track the face in the frames' pixels (MediaPipe models)."""

    inference: Annotated[
        str,
        msgspec.Meta(
            description=f"tracker inference runtime: {', '.join(backend_choices())} "
            "(default auto: LiteRT when installed)"
        ),
    ] = "auto"
    threads: Annotated[
        int, msgspec.Meta(ge=1, le=64, description="tracker inference threads (default 1)")
    ] = 1
    select: Annotated[
        Literal["largest", "score"],
        msgspec.Meta(
            description="several faces: follow the largest (default) or best-scoring one, "
            "then stick to it"
        ),
    ] = "largest"
    redetect_every: Annotated[
        int,
        msgspec.Meta(
            ge=1,
            description="while tracking, re-check with the face detector every N frames "
            "(default 30)",
        ),
    ] = 30

    def __post_init__(self) -> None:
        check_backend_name(self.inference)  # the runtimes registered, installed here or not


@BACKENDS.register(TrackerConfig)
class TrackerBackend(PointsBackend):
    """Live face tracking on the frames' pixels."""

    name = "tracker"

    def __init__(self, config: TrackerConfig | None = None) -> None:
        from services.points.tracker import FaceTracker  # OpenCV and the models: tracker hosts

        config = config or TrackerConfig()
        self.tracker = FaceTracker(
            backend=config.inference,
            redetect_every=config.redetect_every,
            select=config.select,
            num_threads=config.threads,
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
