"""The 52 ARKit-style blendshapes from Face Landmarker v2's points (``face_blendshapes.tflite``).

The model takes 146 of the 478 points, as x, y in the frame's pixels, and gives 52 scores in
[0, 1] in the order of :data:`facesynth.runtime.blendshapes.NAMES`. Which points, in which
order, and how they are scaled is MediaPipe's, from google-ai-edge/mediapipe:

* ``mediapipe/tasks/cc/vision/face_landmarker/face_blendshapes_graph.cc``:
  ``kLandmarksSubsetIdxs`` (the 146 indices below, in that order: a
  ``SplitNormalizedLandmarkListCalculator`` with one range per index, outputs combined), then a
  ``LandmarksToTensorCalculator`` with attributes ``X`` and ``Y``, ``flatten = false`` and the
  input image's size, giving a 1x146x2 tensor; ``kBlendshapeNames`` for the output order;
* ``mediapipe/calculators/tensor/landmarks_to_tensor_calculator.cc``: for normalized landmarks
  ``x`` is multiplied by the image width and ``y`` by the image height, i.e. the points in frame
  pixels, which is what the tracker already holds (the graph feeds it the landmarks projected
  back onto the whole input image, with that image's size).

No other normalisation happens outside the model.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from facesynth.runtime.blendshapes import COUNT

from .runtimes import Model

__all__ = ["LANDMARK_SUBSET", "OUTPUT", "Blendshapes"]

#: ``kLandmarksSubsetIdxs`` of face_blendshapes_graph.cc: the model's 146 input points.
LANDMARK_SUBSET: Final[tuple[int, ...]] = (
    0, 1, 4, 5, 6, 7, 8, 10, 13, 14, 17, 21, 33, 37, 39,
    40, 46, 52, 53, 54, 55, 58, 61, 63, 65, 66, 67, 70, 78, 80,
    81, 82, 84, 87, 88, 91, 93, 95, 103, 105, 107, 109, 127, 132, 133,
    136, 144, 145, 146, 148, 149, 150, 152, 153, 154, 155, 157, 158, 159, 160,
    161, 162, 163, 168, 172, 173, 176, 178, 181, 185, 191, 195, 197, 234, 246,
    249, 251, 263, 267, 269, 270, 276, 282, 283, 284, 285, 288, 291, 293, 295,
    296, 297, 300, 308, 310, 311, 312, 314, 317, 318, 321, 323, 324, 332, 334,
    336, 338, 356, 361, 362, 365, 373, 374, 375, 377, 378, 379, 380, 381, 382,
    384, 385, 386, 387, 388, 389, 390, 397, 398, 400, 402, 405, 409, 415, 454,
    466, 468, 469, 470, 471, 472, 473, 474, 475, 476, 477,
)  # fmt: skip
OUTPUT: Final = "StatefulPartitionedCall:0"
_SUBSET = np.asarray(LANDMARK_SUBSET, np.intp)


class Blendshapes:
    """Runs the blendshape model on a 478-point face."""

    def __init__(self, model: Model) -> None:
        """Args:
        model: :data:`~facesynth.services.points.tracker.model_files.BLENDSHAPES`, batch 1.
        """
        if model.spec.item_shape != (len(LANDMARK_SUBSET), 2) or model.batch != 1:
            raise ValueError("the blendshape model takes one 146x2 point set")
        self.model = model

    def run(self, points478: np.ndarray) -> np.ndarray:
        """The 52 scores (float32, in [0, 1], ARKit order) of one face.

        Args:
            points478: (478, 2 or 3) points in frame pixels (x, y used).

        Raises:
            ValueError: not 478 points.
        """
        if points478.ndim != 2 or points478.shape[0] != 478 or points478.shape[1] < 2:
            raise ValueError(f"expected (478, 2|3) points, got {points478.shape}")
        self.model.input_view()[0] = points478[_SUBSET, :2]
        scores = self.model.run()[OUTPUT][0]
        if scores.shape != (COUNT,):
            raise ValueError(f"the blendshape model gave {scores.shape[0]} scores, not {COUNT}")
        result: np.ndarray = np.clip(scores, 0.0, 1.0).astype(np.float32)
        return result
