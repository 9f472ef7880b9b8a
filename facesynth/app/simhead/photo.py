"""The simulated head's face: the bundled photo and its landmarks (see ``data/PROVENANCE.md``)."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Final

import cv2
import numpy as np

from facesynth.app.simhead.faces import Face

__all__ = ["PHOTO_SIZE", "PhotoError", "bundled_face", "load_face"]

#: The bundled photo's size (width, height).
PHOTO_SIZE: Final = (320, 320)


class PhotoError(ValueError):
    """A face photo or its landmark file cannot be used."""


def _data() -> Path:
    return Path(str(resources.files("facesynth.app.simhead") / "data"))


def load_face(image_path: Path, landmarks_path: Path) -> Face:
    """A face from a photo and a landmark file (JSON: ``points``, 478 rows of x, y, z pixels)."""
    image = cv2.imread(str(image_path), cv2.IMREAD_COLOR)
    if image is None:
        raise PhotoError(f"{image_path}: not an image OpenCV can read")
    try:
        doc = json.loads(landmarks_path.read_text(encoding="utf-8"))
        points = np.asarray(doc["points"], dtype=np.float64)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise PhotoError(f"{landmarks_path}: not a landmark file ({exc})") from None
    if points.shape != (478, 3) or not np.isfinite(points).all():
        raise PhotoError(f"{landmarks_path}: expected 478 finite (x, y, z) points")
    h, w = image.shape[:2]
    if (
        (points[:, 0] < 0).any()
        or (points[:, 0] >= w).any()
        or (points[:, 1] < 0).any()
        or (points[:, 1] >= h).any()
    ):
        raise PhotoError(f"{landmarks_path}: points outside the {w}x{h} image")
    return Face(image, points)


def bundled_face() -> Face:
    """The bundled photo (320x320, BGR) and its Face Landmarker v2 landmarks."""
    data = _data()
    return load_face(data / "face.jpg", data / "face_landmarks.json")
