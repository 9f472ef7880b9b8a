"""The ``fast`` tracker model: the 468-point face mesh, then the iris model on both eyes.

Two model calls per frame: ``face_landmark.tflite`` on the 192x192 face crop, then
``iris_landmark.tflite`` on both 64x64 eye crops in one batch of two (:mod:`..iris`). No
blendshapes. With ``iris = false`` only the mesh runs.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Annotated

import msgspec
import numpy as np

from . import TRACKER_MODELS, Landmarks, ModelLoader, TrackerModel

if TYPE_CHECKING:
    from ..crops import CropRect

__all__ = ["FastModel", "FastTrackerModel"]


class FastModel(
    msgspec.Struct, tag="fast", tag_field="model", forbid_unknown_fields=True, kw_only=True
):
    """Options of the ``fast`` model."""

    iris: Annotated[
        bool, msgspec.Meta(description="run the iris model (about half the per-frame cost)")
    ] = True


@TRACKER_MODELS.register(FastModel)
class FastTrackerModel(TrackerModel):
    """468-point mesh + iris model on both eyes: two model calls, no blendshapes."""

    name = "fast"

    def __init__(self, config: FastModel, load: ModelLoader) -> None:
        from ..iris import IrisLandmarks
        from ..mesh import FaceMesh
        from ..model_files import IRIS, MESH

        self.config = config
        self.mesh_model = FaceMesh(load(MESH, 1))
        self.iris = IrisLandmarks(load(IRIS, 2)) if config.iris else None
        self.timing_keys = ("iris",) if config.iris else ()

    def mesh(self, frame_rgba: np.ndarray, rect: CropRect) -> tuple[np.ndarray, float]:
        """See :meth:`TrackerModel.mesh` (468 points)."""
        return self.mesh_model.run(frame_rgba, rect)

    def extras(
        self, frame_rgba: np.ndarray, points: np.ndarray, timings: dict[str, float]
    ) -> Landmarks:
        """The irises (:mod:`..iris`), when enabled."""
        if self.iris is None:
            return Landmarks()
        t = time.perf_counter()
        iris = self.iris.run(frame_rgba, points)
        timings["iris"] = timings.get("iris", 0.0) + (time.perf_counter() - t) * 1e3
        return Landmarks(iris=iris)
