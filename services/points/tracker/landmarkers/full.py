"""The ``full`` tracker model: Face Landmarker v2 (478 points) and the 52 blendshapes.

One call of ``face_landmarks_detector.tflite`` on a 256x256 face crop (chosen by the same rule
as the mesh's: eye-aligned, 1.5x the face box, as MediaPipe's ``face_landmarks_detector_graph``)
gives the 468 mesh vertices and both irises (points 468-472: the performer's right iris, centre
then 4 contour points; 473-477: the left one). The v2 model orders both contours the same way
in the image (toward image right, up, image left, down); the iris model, and so ``iris10``
of the ``fast`` model, mirrors the left eye's (toward the nose, up, away from it, down), so
``iris10`` here takes the left contour in that order too and means the same for both models.
Then ``face_blendshapes.tflite`` turns 146 of those points into the 52 ARKit-style
blendshapes (:mod:`..blendshapes`), unless ``blendshapes = false``.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Annotated

import msgspec
import numpy as np

from . import TRACKER_MODELS, Landmarks, ModelLoader, TrackerModel

if TYPE_CHECKING:
    from ..crops import CropRect

__all__ = ["NUM_POINTS", "FullModel", "FullTrackerModel"]

NUM_POINTS = 478
#: Rows of the 478 points that make iris10 (right centre + 4, then left centre + 4, the left
#: contour mirrored to the iris model's order).
IRIS_ROWS = np.array([468, 469, 470, 471, 472, 473, 476, 475, 474, 477])


class FullModel(
    msgspec.Struct, tag="full", tag_field="model", forbid_unknown_fields=True, kw_only=True
):
    """Options of the ``full`` model."""

    blendshapes: Annotated[
        bool, msgspec.Meta(description="run the blendshape model (about 0.4 ms a frame)")
    ] = True


@TRACKER_MODELS.register(FullModel)
class FullTrackerModel(TrackerModel):
    """Face Landmarker v2: 478 points with the irises in one call, + 52 blendshapes."""

    name = "full"

    def __init__(self, config: FullModel, load: ModelLoader) -> None:
        from ..blendshapes import Blendshapes
        from ..mesh import FaceMesh
        from ..model_files import BLENDSHAPES, LANDMARKS_V2

        self.config = config
        self.landmarks = FaceMesh(load(LANDMARKS_V2, 1), NUM_POINTS, "Identity", "Identity_1")
        self.blendshapes = Blendshapes(load(BLENDSHAPES, 1)) if config.blendshapes else None
        self.timing_keys = ("blendshapes",) if config.blendshapes else ()

    def mesh(self, frame_rgba: np.ndarray, rect: CropRect) -> tuple[np.ndarray, float]:
        """See :meth:`TrackerModel.mesh` (478 points)."""
        return self.landmarks.run(frame_rgba, rect)

    def extras(
        self, frame_rgba: np.ndarray, points: np.ndarray, timings: dict[str, float]
    ) -> Landmarks:
        """The irises (from the same call), the 478 points and the blendshapes."""
        scores = None
        if self.blendshapes is not None:
            t = time.perf_counter()
            scores = self.blendshapes.run(points)
            elapsed = (time.perf_counter() - t) * 1e3
            timings["blendshapes"] = timings.get("blendshapes", 0.0) + elapsed
        return Landmarks(iris=points[IRIS_ROWS, :2], mesh478=points, blendshapes=scores)
