"""The paper's eye-corner face frame of the 68 points (pure numpy).

The two outer eye corners (36, 45) define it: origin at their midpoint, x axis along the eye
line (toward the performer's left), unit length = their distance (inter-ocular distance, IOD).
As in the image, y points down.
"""

from __future__ import annotations

import numpy as np

from facesynth.runtime.landmarks import LEFT_EYE_OUTER, RIGHT_EYE_OUTER

#: Eye corners closer than this (pixels) cannot define a face frame.
MIN_IOD_PX = 1e-3


class FeatureError(ValueError):
    """Points from which no features can be computed (missing scheme, degenerate eyes)."""


def normalise(points: np.ndarray, frame_of: np.ndarray | None = None) -> np.ndarray:
    """Points in the eye-corner face frame: translation, rotation and scale removed. The frame
    is set by the outer eye corners of ``points``, or of ``frame_of`` (68 points of another
    face, e.g. the neutral's, when ``points`` were already moved to its pose)."""
    corners = points if frame_of is None else frame_of
    right, left = corners[RIGHT_EYE_OUTER], corners[LEFT_EYE_OUTER]
    axis = left - right
    iod = float(np.hypot(axis[0], axis[1]))
    if not np.isfinite(iod) or iod < MIN_IOD_PX:
        raise FeatureError(f"outer eye corners are {iod:.3g} px apart: no face frame")
    cos, sin = axis / iod
    rotation = np.array([[cos, sin], [-sin, cos]])
    result: np.ndarray = ((points - (right + left) / 2.0) @ rotation.T) / iod
    return result
