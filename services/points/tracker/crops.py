"""Pure maths for rotated square crops (face and eye crops).

A crop is described by a :class:`CropRect`: a centre in frame pixels, a rotation angle and a
side length. The angle is the direction of the line through the two eyes (or eye corners) in the
frame, measured in radians in image coordinates (x to the right, y *down*), so a positive angle
means the line goes down to the right. Sampling the crop with :func:`crop_affine` makes that line
horizontal in the crop.

Conventions follow MediaPipe's ``ImageToTensorCalculator``: the four corners of the rotated
square map onto the corners ``(0, 0)``..``(size, size)`` of the output, so that a point at the
rect centre lands at ``(size / 2, size / 2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CropRect",
    "compose_affine",
    "crop_affine",
    "flip_horizontal_affine",
    "invert_affine",
    "rect_from_box",
    "rect_from_points",
    "rotation_angle",
    "transform_points",
]


@dataclass(frozen=True, slots=True)
class CropRect:
    """A rotated square region of a frame.

    Attributes:
        cx: centre x in frame pixels.
        cy: centre y in frame pixels.
        angle: rotation in radians (image coordinates, y down); the crop's x axis points along
            ``(cos(angle), sin(angle))`` in the frame.
        side: side length in frame pixels (> 0).
    """

    cx: float
    cy: float
    angle: float
    side: float

    def corners(self) -> np.ndarray:
        """Return the four corners in frame pixels (top-left, top-right, bottom-right,
        bottom-left of the crop), shape (4, 2) float64."""
        h = self.side / 2.0
        c, s = math.cos(self.angle), math.sin(self.angle)
        u = np.array([c, s]) * h
        v = np.array([-s, c]) * h
        centre = np.array([self.cx, self.cy])
        return np.stack([centre - u - v, centre + u - v, centre + u + v, centre - u + v])

    def bbox(self) -> tuple[float, float, float, float]:
        """Axis-aligned bounding box of the rotated square as (x, y, w, h)."""
        c = self.corners()
        x0, y0 = c.min(axis=0)
        x1, y1 = c.max(axis=0)
        return float(x0), float(y0), float(x1 - x0), float(y1 - y0)


def rotation_angle(start: np.ndarray, end: np.ndarray) -> float:
    """Angle (radians, image coordinates) of the vector from ``start`` to ``end``.

    For the eye line (subject's right eye -> left eye, i.e. image left -> image right) this is
    0 for an upright face and positive when the face is rolled clockwise on screen.
    """
    d = np.asarray(end, dtype=np.float64) - np.asarray(start, dtype=np.float64)
    return float(math.atan2(d[1], d[0]))


def crop_affine(rect: CropRect, size: int) -> np.ndarray:
    """2x3 affine (float64) mapping frame pixels to crop pixels for a ``size`` x ``size`` crop.

    Use it with ``cv2.warpAffine(frame, M, (size, size))``. The crop's x axis follows
    ``rect.angle`` in the frame, so a line at that angle becomes horizontal.
    """
    if not (rect.side > 0 and math.isfinite(rect.side)):
        raise ValueError(f"crop side must be a positive finite number, got {rect.side}")
    k = size / rect.side
    c, s = math.cos(rect.angle) * k, math.sin(rect.angle) * k
    # q = k * R(-angle) (p - centre) + size / 2
    h = size / 2.0
    return np.array(
        [
            [c, s, h - c * rect.cx - s * rect.cy],
            [-s, c, h + s * rect.cx - c * rect.cy],
        ]
    )


def invert_affine(m: np.ndarray) -> np.ndarray:
    """Inverse of a 2x3 affine transform (float64).

    Raises:
        ValueError: the transform is singular.
    """
    (a, b, c), (d, e, f) = np.asarray(m, dtype=np.float64).tolist()
    det = a * e - b * d
    if det == 0.0 or not math.isfinite(det):
        raise ValueError("affine transform is not invertible")
    ia, ib, id_, ie = e / det, -b / det, -d / det, a / det
    return np.array([[ia, ib, -(ia * c + ib * f)], [id_, ie, -(id_ * c + ie * f)]])


def compose_affine(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """The 2x3 affine ``outer ∘ inner`` (apply ``inner`` first)."""
    o = np.asarray(outer, dtype=np.float64)
    i = np.asarray(inner, dtype=np.float64)
    return np.hstack([o[:, :2] @ i[:, :2], (o[:, :2] @ i[:, 2] + o[:, 2])[:, None]])


def flip_horizontal_affine(size: int) -> np.ndarray:
    """2x3 affine mirroring a ``size``-wide crop left/right (x -> size - x)."""
    return np.array([[-1.0, 0.0, float(size)], [0.0, 1.0, 0.0]])


def transform_points(m: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 2x3 affine to points of shape (N, 2) or (N, >=2); extra columns are dropped.

    Returns float64 (N, 2).
    """
    p = np.asarray(points, dtype=np.float64)[..., :2]
    m = np.asarray(m, dtype=np.float64)
    return p @ m[:, :2].T + m[:, 2]


def rect_from_box(
    x0: float, y0: float, x1: float, y1: float, angle: float, scale: float
) -> CropRect:
    """MediaPipe-style square crop from an axis-aligned box: centred on the box, rotated by
    ``angle``, side ``scale * max(width, height)``."""
    side = scale * max(x1 - x0, y1 - y0)
    return CropRect((x0 + x1) / 2.0, (y0 + y1) / 2.0, angle, side)


def rect_from_points(points: np.ndarray, start: int, end: int, scale: float) -> CropRect:
    """Square crop around a point set (MediaPipe's landmarks-to-ROI rule).

    Centre and size come from the axis-aligned bounding box of ``points[:, :2]``; the angle from
    ``points[start]`` to ``points[end]``; side = ``scale`` x the longer box side.
    """
    p = np.asarray(points)
    xs, ys = p[:, 0], p[:, 1]
    x0, x1, y0, y1 = float(xs.min()), float(xs.max()), float(ys.min()), float(ys.max())
    angle = math.atan2(float(ys[end] - ys[start]), float(xs[end] - xs[start]))
    return rect_from_box(x0, y0, x1, y1, angle, scale)
