"""The face tracker as a point streamer backend (P's default).

Decodes each frame, runs :class:`services.points.tracker.FaceTracker` with the chosen tracker
model (``facesynth.services.points.tracker.landmarkers``) and publishes:

* ``fast`` model: ``ibug68`` (the paper's 68 points, derived from the mesh), ``mesh468``
  (x, y, z) and ``iris10``;
* ``full`` model: ``ibug68`` (from the same 468 vertices), ``mesh478`` (x, y, z: the mesh, then
  both irises), ``iris10`` (the same irises as 2D points, so every reader of ``iris10`` keeps
  working) and, unless ``blendshapes = false``, the ``blendshapes52`` score set.

A frame without a face gives "no face", never the previous frame's points.
"""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec
import numpy as np

from facesynth.runtime.blendshapes import BLENDSHAPES52
from facesynth.runtime.landmarks import IBUG68, IRIS10, MESH468, MESH478
from facesynth.schemas.messages import Frame, Points, ScoreSet
from facesynth.services.points.backends.base import (
    BackendError,
    PointsBackend,
    face_points,
    no_face,
    point_set,
)
from facesynth.services.points.backends.registry import BACKENDS
from facesynth.services.points.tracker.landmarkers import TRACKER_MODELS, model_config
from facesynth.services.points.tracker.runtimes import backend_choices, check_backend_name


def _model_help() -> str:
    """``--model`` help, from the tracker-model registry (no OpenCV imported)."""
    models = "; ".join(f"{p.name} = {p.summary.rstrip('.')}" for p in TRACKER_MODELS)
    return f"tracker model (default full): {models}"


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
        int,
        msgspec.Meta(
            ge=1, le=64, description="tracker threads: inference and OpenCV's (default 1)"
        ),
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
    model: Annotated[str, msgspec.Meta(description=_model_help())] = "full"
    blendshapes: Annotated[
        bool,
        msgspec.Meta(
            description="with --model full: run the blendshape model (about 0.4 ms a frame)"
        ),
    ] = True

    def __post_init__(self) -> None:
        check_backend_name(self.inference)  # the runtimes registered, installed here or not
        if self.model not in TRACKER_MODELS:
            known = ", ".join(TRACKER_MODELS.names())
            raise ValueError(f"unknown tracker model {self.model!r} (known: {known})")

    def model_config(self) -> msgspec.Struct:
        """The tracker model's own config: its name and those of its options set here."""
        fields = {f.name for f in TRACKER_MODELS.get(self.model).fields()}
        options = {name: getattr(self, name) for name in ("blendshapes",) if name in fields}
        return model_config(self.model, **options)


@BACKENDS.register(TrackerConfig)
class TrackerBackend(PointsBackend):
    """Live face tracking on the frames' pixels."""

    needs_extra = "tracker"

    name = "tracker"

    def __init__(self, config: TrackerConfig | None = None) -> None:
        from facesynth.runtime.opencv import import_cv2
        from facesynth.services.points.tracker import (
            FaceTracker,  # OpenCV and the models: tracker hosts
        )
        from facesynth.services.points.tracker.jpeg_rgba import decode_rgba

        self._decode_rgba = decode_rgba

        config = config or TrackerConfig()
        # OpenCV's own thread pool (crops, colour conversion) gets the tracker's thread count:
        # by default it starts one worker per core, which then spins in sched_yield between
        # frames (a sixth of P's CPU time at 30 fps, measured with perf).
        import_cv2(BackendError).setNumThreads(config.threads)
        self.tracker = FaceTracker(
            backend=config.inference,
            redetect_every=config.redetect_every,
            select=config.select,
            num_threads=config.threads,
            model=config.model_config(),
        )
        self._rgba: np.ndarray | None = None

    def needs_pixels(self) -> bool:
        return True

    def gives_blendshapes(self) -> bool:
        return bool(getattr(self.tracker.model_config, "blendshapes", False))

    def process(self, frame: Frame) -> Points:
        if frame.encoding == "none":
            raise BackendError(f"frame {frame.seq} has no pixels: the tracker needs images")
        self._rgba = self._decode_rgba(frame, self._rgba)  # one frame's buffer, reused
        result = self.tracker.process_rgba(self._rgba)
        if not result.face or result.ibug68 is None or result.mesh is None:
            return no_face(frame, self.name, result.presence)
        sets = [point_set(IBUG68, result.ibug68)]
        if result.mesh478 is not None:
            sets.append(point_set(MESH478, result.mesh478))
        else:
            sets.append(point_set(MESH468, result.mesh))
        if result.iris is not None:
            sets.append(point_set(IRIS10, result.iris))
        scores = None
        if result.blendshapes is not None:
            values = result.blendshapes.astype(float).tolist()
            scores = [ScoreSet(scheme=BLENDSHAPES52, values=values)]
        return face_points(frame, sets, result.presence, self.name, scores)
