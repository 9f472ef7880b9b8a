"""Iris landmarks (MediaPipe ``iris_landmark.tflite``) on two 64x64 eye crops.

Each eye crop is centred between the eye's two corners (mesh vertices 33/133 for the subject's
right eye — image left — and 362/263 for the left eye — image right), rotated so the corner line
is horizontal, with side 2.3x the corners' bounding box (MediaPipe's iris ROI rule). The model
expects the eye with its outer corner on the crop's left, so the subject's *left* eye crop is
mirrored. Both crops run as one batch of two.

Verified on the sample video: with this orientation the model's 71-point eye contour agrees
with the mesh's own eye-region vertices point by point (about 0.02-0.03 inter-ocular distances
for the 16 eye-contour points); with the wrong mirroring the error is about 0.16.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .crops import (
    CropRect,
    crop_affine,
    invert_affine,
    rect_from_box,
)
from .model_input import fill_input
from .runtimes import Model

__all__ = [
    "EYE_CONTOUR_VERTICES",
    "EYE_CORNERS",
    "IRIS_SIZE",
    "IrisLandmarks",
    "eye_rects",
]

IRIS_SIZE = 64
EYE_ROI_SCALE = 2.3
#: (first, second) mesh corner vertices per eye, subject's right eye first. The crop's
#: x axis points from first to second (image left to image right).
EYE_CORNERS: tuple[tuple[int, int], tuple[int, int]] = ((33, 133), (362, 263))
#: Whether each eye crop is mirrored (so the outer corner is on the crop's left).
EYE_FLIPPED: tuple[bool, bool] = (False, True)
#: Mesh vertices matching the first 16 points (eye contour) of the model's
#: ``output_eyes_contours_and_brows``, per eye (MediaPipe's update_face_landmarks mapping).
EYE_CONTOUR_VERTICES: tuple[tuple[int, ...], tuple[int, ...]] = (
    (33, 7, 163, 144, 145, 153, 154, 155, 133, 246, 161, 160, 159, 158, 157, 173),
    (263, 249, 390, 373, 374, 380, 381, 382, 362, 466, 388, 387, 386, 385, 384, 398),
)


def eye_rects(mesh: np.ndarray, scale: float = EYE_ROI_SCALE) -> tuple[CropRect, CropRect]:
    """Eye crops (subject's right eye, left eye) from a mesh in frame pixels."""
    rects = []
    for a, b in EYE_CORNERS:
        xa, ya = float(mesh[a, 0]), float(mesh[a, 1])
        xb, yb = float(mesh[b, 0]), float(mesh[b, 1])
        rects.append(
            rect_from_box(
                min(xa, xb),
                min(ya, yb),
                max(xa, xb),
                max(ya, yb),
                math.atan2(yb - ya, xb - xa),
                scale,
            )
        )
    return rects[0], rects[1]


def eye_affines(mesh: np.ndarray) -> list[np.ndarray]:
    """Frame -> eye-crop affines (mirroring included), subject's right eye first."""
    out = []
    for rect, flip in zip(eye_rects(mesh), EYE_FLIPPED, strict=True):
        m = crop_affine(rect, IRIS_SIZE)
        if flip:  # flip_horizontal_affine(IRIS_SIZE) ∘ m, written out
            m[0] *= -1.0
            m[0, 2] += IRIS_SIZE
        out.append(m)
    return out


class IrisLandmarks:
    """Runs the iris model on both eyes of a mesh."""

    def __init__(self, model: Model) -> None:
        """Args:
        model: the iris model (:data:`~services.points.tracker.model_files.IRIS`) loaded with
            ``batch=2``.
        """
        if model.input_size != IRIS_SIZE or model.batch != 2:
            raise ValueError("iris model must have a 64x64 input and batch=2")
        self.model = model
        self._crops = np.zeros((2, IRIS_SIZE, IRIS_SIZE, 4), np.uint8)
        self._rgb = np.zeros((IRIS_SIZE, IRIS_SIZE, 3), np.uint8)
        self.last_contours: np.ndarray | None = None

    def run(self, frame_rgba: np.ndarray, mesh: np.ndarray) -> np.ndarray:
        """Iris points for both eyes.

        Returns:
            (10, 2) float32 frame pixels: subject's right eye (image left) centre then 4 contour
            points, then the same for the left eye. The model's eye contours and brows
            (2, 71, 2) are kept in :attr:`last_contours`.
        """
        affines = eye_affines(mesh)
        for i, m in enumerate(affines):
            # (the view is re-fetched per eye and dropped before run(): see Model.input_view)
            cv2.warpAffine(
                frame_rgba,
                m,
                (IRIS_SIZE, IRIS_SIZE),
                dst=self._crops[i],
                flags=cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=(0, 0, 0, 0),
            )
            fill_input(self.model.input_view()[i], self._crops[i], 1.0 / 255.0, 0.0, self._rgb)
        out = self.model.run()
        iris = np.empty((10, 2), np.float32)
        contours = np.empty((2, 71, 2), np.float32)
        for i, m in enumerate(affines):
            inv = invert_affine(m)
            p = out["output_iris"][i].reshape(5, 3)[:, :2]
            iris[5 * i : 5 * i + 5] = p @ inv[:, :2].T + inv[:, 2]
            c = out["output_eyes_contours_and_brows"][i].reshape(71, 3)[:, :2]
            contours[i] = c @ inv[:, :2].T + inv[:, 2]
        self.last_contours = contours
        return iris
