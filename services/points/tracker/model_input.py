"""Frames to model inputs: BGR/grey frames to RGBA, RGBA crops to scaled float32 RGB."""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["fill_input", "frame_to_rgba"]


def frame_to_rgba(image: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Convert a uint8 BGR (H, W, 3), BGRA (H, W, 4) or grey (H, W) frame to RGBA.

    Four-channel images are what ``cv2.warpAffine`` resamples fastest. ``out`` is reused when
    it has the right shape.

    Raises:
        ValueError: not a uint8 image of one of those shapes, or empty.
    """
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8:
        raise ValueError("expected a uint8 numpy image")
    if image.ndim == 2:
        code = cv2.COLOR_GRAY2RGBA
    elif image.ndim == 3 and image.shape[2] == 3:
        code = cv2.COLOR_BGR2RGBA
    elif image.ndim == 3 and image.shape[2] == 4:
        code = cv2.COLOR_BGRA2RGBA
    else:
        raise ValueError(f"expected an (H, W), (H, W, 3) or (H, W, 4) image, got {image.shape}")
    h, w = image.shape[:2]
    if h < 1 or w < 1:
        raise ValueError("empty image")
    if out is None or out.shape != (h, w, 4):
        out = np.empty((h, w, 4), np.uint8)
    cv2.cvtColor(image, code, dst=out)
    return out


def fill_input(
    dst: np.ndarray, crop_rgba: np.ndarray, scale: float, offset: float, scratch: np.ndarray
) -> None:
    """Write ``rgb * scale + offset`` of a uint8 RGBA crop into a float32 (S, S, 3) view.

    ``scratch`` is a uint8 (S, S, 3) buffer reused for the RGBA -> RGB step.
    """
    cv2.cvtColor(crop_rgba, cv2.COLOR_RGBA2RGB, dst=scratch)
    np.multiply(scratch, np.float32(scale), out=dst)
    if offset:
        np.add(dst, np.float32(offset), out=dst)
