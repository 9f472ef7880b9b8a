"""468-point face mesh (MediaPipe ``face_landmark.tflite``) on an eye-aligned 192x192 crop.

The crop comes either from a detection (box centre, eye keypoints for the angle, side 1.5x the
box) or, while tracking, from the previous frame's mesh (bounding box of all vertices, angle
from vertex 33 to vertex 263 — the outer eye corners — side 1.5x the longer box side), as in
MediaPipe's face-landmark graphs.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .crops import CropRect, crop_affine, invert_affine, rect_from_box, rect_from_points
from .detector import Detection
from .model_input import fill_input
from .runtimes import Model

__all__ = [
    "LEFT_EYE_OUTER",
    "MESH_SIZE",
    "NUM_VERTICES",
    "RIGHT_EYE_OUTER",
    "FaceMesh",
    "mesh_box",
    "rect_from_detection",
    "rect_from_mesh",
    "rect_from_mesh_box",
    "sigmoid",
]

MESH_SIZE = 192
NUM_VERTICES = 468
#: Outer corner of the subject's right eye (image left) and left eye (image right).
RIGHT_EYE_OUTER = 33
LEFT_EYE_OUTER = 263
ROI_SCALE = 1.5


def sigmoid(x: float) -> float:
    """Numerically safe logistic function."""
    x = min(100.0, max(-100.0, float(x)))
    return 1.0 / (1.0 + math.exp(-x))


def rect_from_detection(det: Detection, scale: float = ROI_SCALE) -> CropRect:
    """Mesh crop from a detection: box centre, eye-line angle, ``scale`` x the longer side."""
    x0, y0, x1, y1 = det.box
    d = det.keypoints[1] - det.keypoints[0]
    return rect_from_box(x0, y0, x1, y1, math.atan2(float(d[1]), float(d[0])), scale)


def rect_from_mesh(mesh: np.ndarray, scale: float = ROI_SCALE) -> CropRect:
    """Mesh crop for the next frame from this frame's mesh (frame pixels)."""
    return rect_from_points(mesh, RIGHT_EYE_OUTER, LEFT_EYE_OUTER, scale)


def mesh_box(mesh: np.ndarray) -> tuple[float, float, float, float]:
    """Axis-aligned bounding box (x, y, w, h) of a mesh's x, y."""
    xs, ys = mesh[:, 0], mesh[:, 1]
    x0, y0 = float(xs.min()), float(ys.min())
    return x0, y0, float(xs.max()) - x0, float(ys.max()) - y0


def rect_from_mesh_box(
    mesh: np.ndarray, box: tuple[float, float, float, float], scale: float = ROI_SCALE
) -> CropRect:
    """Same as :func:`rect_from_mesh` when ``box`` is :func:`mesh_box` of ``mesh``."""
    a, b = mesh[RIGHT_EYE_OUTER], mesh[LEFT_EYE_OUTER]
    angle = math.atan2(float(b[1] - a[1]), float(b[0] - a[0]))
    x, y, w, h = box
    return rect_from_box(x, y, x + w, y + h, angle, scale)


class FaceMesh:
    """Runs the mesh model on one crop and maps the result back to frame pixels."""

    def __init__(self, model: Model) -> None:
        """Args:
        model: the loaded mesh model (:data:`~services.points.tracker.model_files.MESH`).
        """
        if model.input_size != MESH_SIZE:
            raise ValueError(f"mesh input must be {MESH_SIZE}, got {model.input_size}")
        self.model = model
        self._crop = np.zeros((MESH_SIZE, MESH_SIZE, 4), np.uint8)
        self._rgb = np.zeros((MESH_SIZE, MESH_SIZE, 3), np.uint8)

    def run(self, frame_rgba: np.ndarray, rect: CropRect) -> tuple[np.ndarray, float]:
        """Mesh for the face inside ``rect``.

        Args:
            frame_rgba: uint8 RGBA frame (:func:`~.model_input.frame_to_rgba`).
            rect: the crop.

        Returns:
            (mesh, presence): mesh (468, 3) float32 with x, y in frame pixels and z (relative
            depth, smaller = nearer the camera) in the same pixel scale; presence in [0, 1].
        """
        m = crop_affine(rect, MESH_SIZE)
        cv2.warpAffine(
            frame_rgba,
            m,
            (MESH_SIZE, MESH_SIZE),
            dst=self._crop,
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(0, 0, 0, 0),
        )
        fill_input(self.model.input_view()[0], self._crop, 1.0 / 255.0, 0.0, self._rgb)
        out = self.model.run()
        pts = out["conv2d_21"][0].reshape(NUM_VERTICES, 3)
        inv = invert_affine(m)
        mesh = np.empty((NUM_VERTICES, 3), np.float32)
        mesh[:, :2] = pts[:, :2] @ inv[:, :2].T + inv[:, 2]
        mesh[:, 2] = pts[:, 2] * (rect.side / MESH_SIZE)
        return mesh, sigmoid(float(out["conv2d_31"][0, 0]))
