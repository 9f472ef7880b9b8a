"""The paper's eye-corner face frame of the 68 points (pure numpy).

The two outer eye corners (36, 45) define it: origin at their midpoint, x axis along the eye
line (toward the performer's left), unit length = their distance (inter-ocular distance, IOD).
As in the image, y points down.
"""

from __future__ import annotations

import math

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
    # the corners as plain floats: the same arithmetic as on numpy scalars, for less
    rx, ry = corners[RIGHT_EYE_OUTER].tolist()
    lx, ly = corners[LEFT_EYE_OUTER].tolist()
    ax, ay = lx - rx, ly - ry
    iod = float(np.hypot(ax, ay))
    if not math.isfinite(iod) or iod < MIN_IOD_PX:
        raise FeatureError(f"outer eye corners are {iod:.3g} px apart: no face frame")
    cos, sin = ax / iod, ay / iod
    rotation = np.array([[cos, sin], [-sin, cos]])
    centre = np.array([(rx + lx) / 2.0, (ry + ly) / 2.0])
    result: np.ndarray = ((points - centre) @ rotation.T) / iod
    return result
