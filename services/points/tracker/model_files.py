"""The bundled MediaPipe model files: what the engine expects of each, and reading one.

Every model file is read once and its SHA-256 checked against the bundled value before a
runtime is built from it, so a missing, unreadable, truncated or otherwise corrupt file raises
:class:`~facesynth.services.points.tracker.errors.ModelError` instead of crashing later.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

from .errors import ModelError

__all__ = [
    "BLENDSHAPES",
    "DETECTOR",
    "IRIS",
    "LANDMARKS_V2",
    "MESH",
    "MODELS_DIR",
    "ModelSpec",
    "read_model_bytes",
]

MODELS_DIR: Path = Path(__file__).resolve().parent / "models"


@dataclass(frozen=True, slots=True)
class ModelSpec:
    """What the engine expects of one bundled model file.

    Image models take (batch, S, S, 3) with S = ``input_size``; a model with another input
    gives its per-item shape in ``input_shape`` (``input_size`` is then its first dimension).
    """

    filename: str
    sha256: str
    input_size: int
    outputs: tuple[str, ...]
    input_shape: tuple[int, ...] = ()

    @property
    def item_shape(self) -> tuple[int, ...]:
        """The input shape of one item (without the batch dimension)."""
        s = self.input_size
        return self.input_shape or (s, s, 3)


DETECTOR = ModelSpec(
    "face_detection_short_range.tflite",
    "bbff11cebd1eb27a1e004cae0b0e63ec8c551cbf34a4451148b4908b8db3eca8",
    128,
    ("regressors", "classificators"),
)
MESH = ModelSpec(
    "face_landmark.tflite",
    "1055cb9d4a9ca8b8c688902a3a5194311138ba256bcc94e336d8373a5f30c814",
    192,
    ("conv2d_21", "conv2d_31"),
)
IRIS = ModelSpec(
    "iris_landmark.tflite",
    "d1744d2a09c25f501d39eba4faff47e53ecca8852c5ce19bce8eeac39357521f",
    64,
    ("output_iris", "output_eyes_contours_and_brows"),
)
#: Face Landmarker v2 (``face_landmarks_detector.tflite`` from ``face_landmarker.task``): 478
#: points (x, y, z in input pixels), presence logit; ``Identity_2`` is not used.
LANDMARKS_V2 = ModelSpec(
    "face_landmarks_detector.tflite",
    "c7d54204ce0448474c7f3fa9af494787c0965cbdd6f20fc72867e43046bd43d5",
    256,
    ("Identity", "Identity_1"),
)
#: The 52 ARKit-style blendshape scores from 146 of the 478 points (x, y in frame pixels).
BLENDSHAPES = ModelSpec(
    "face_blendshapes.tflite",
    "4f36dded049db18d76048567439b2a7f58f1daabc00d78bfe8f3ad396a2d2082",
    146,
    ("StatefulPartitionedCall:0",),
    input_shape=(146, 2),
)


def read_model_bytes(path: Path | str, expected_sha256: str | None) -> bytes:
    """Read a model file and check its SHA-256 (skipped when ``expected_sha256`` is None).

    Raises:
        ModelError: the file is missing, unreadable, empty or has the wrong checksum.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError as exc:
        raise ModelError(f"model file not found: {p}") from exc
    except OSError as exc:
        raise ModelError(f"model file unreadable: {p}: {exc}") from exc
    if not data:
        raise ModelError(f"model file is empty: {p}")
    if expected_sha256 is not None:
        digest = hashlib.sha256(data).hexdigest()
        if digest != expected_sha256:
            raise ModelError(
                f"model file corrupt: {p} ({len(data)} bytes) has sha256 {digest}, "
                f"expected {expected_sha256} (see models/PROVENANCE.md)"
            )
    return data
