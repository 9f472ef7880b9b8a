"""Face mesh models on an eye-aligned square crop: the 468-point mesh (MediaPipe
``face_landmark.tflite``, 192x192) and, with the same class, Face Landmarker v2
(``face_landmarks_detector.tflite``, 256x256, 478 points: the mesh then the two irises).

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
    """Runs a mesh model on one crop and maps the result back to frame pixels."""

    def __init__(
        self,
        model: Model,
        num_points: int = NUM_VERTICES,
        points_output: str = "conv2d_21",
        presence_output: str = "conv2d_31",
    ) -> None:
        """Args:
        model: the loaded mesh model (:data:`~services.points.tracker.model_files.MESH`, or
            :data:`~services.points.tracker.model_files.LANDMARKS_V2` with 478 points and the
            outputs ``Identity`` / ``Identity_1``).
        num_points: points the model gives (x, y, z each, in crop pixels).
        points_output, presence_output: its output names.
        """
        size = model.input_size
        if model.spec.item_shape != (size, size, 3):
            raise ValueError(f"a mesh model takes a square RGB image, not {model.spec.item_shape}")
        if points_output not in model.spec.outputs or presence_output not in model.spec.outputs:
            raise ValueError(f"{model.spec.filename} has no {points_output}/{presence_output}")
        self.model = model
        self.size = size
        self.num_points = num_points
        self._outputs = (points_output, presence_output)
        self._crop = np.zeros((size, size, 4), np.uint8)
        self._rgb = np.zeros((size, size, 3), np.uint8)

    def run(self, frame_rgba: np.ndarray, rect: CropRect) -> tuple[np.ndarray, float]:
        """Mesh for the face inside ``rect``.

        Args:
            frame_rgba: uint8 RGBA frame (:func:`~.model_input.frame_to_rgba`).
            rect: the crop.

        Returns:
            (mesh, presence): mesh (num_points, 3) float32 with x, y in frame pixels and z
            (relative depth, smaller = nearer the camera) in the same pixel scale; presence in
            [0, 1].
        """
        size = self.size
        m = crop_affine(rect, size)
        cv2.warpAffine(
            frame_rgba,
            m,
            (size, size),
            dst=self._crop,
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(0, 0, 0, 0),
        )
        fill_input(self.model.input_view()[0], self._crop, 1.0 / 255.0, 0.0, self._rgb)
        out = self.model.run()
        points_name, presence_name = self._outputs
        n = self.num_points
        pts = out[points_name][0].reshape(n, 3)
        inv = invert_affine(m)
        mesh = np.empty((n, 3), np.float32)
        mesh[:, :2] = pts[:, :2] @ inv[:, :2].T + inv[:, 2]
        mesh[:, 2] = pts[:, 2] * (rect.side / size)
        return mesh, sigmoid(float(out[presence_name][0, 0]))
