"""Feature processor F, pure core: the paper's pose-free features (section 2.2.2).

The two outer eye corners (36, 45) define a face frame: origin at their midpoint, x axis along
the eye line, unit length = their distance (inter-ocular distance, IOD). In that frame the
distance of every point to the nose tip (30) no longer depends on the head's in-plane position,
rotation or scale. Features are also given relative to the performer's neutral face: from a
calibration, or the median over the first second (media time) in which a face is seen.
"""

from __future__ import annotations

import numpy as np

from facesynth.landmarks import IBUG68, LEFT_EYE_OUTER, N_IBUG, NOSE_TIP, RIGHT_EYE_OUTER
from schemas.messages import Features, Points

#: Eye corners closer than this (pixels) cannot define a face frame.
MIN_IOD_PX = 1e-3


class FeatureError(ValueError):
    """Points from which no features can be computed (missing scheme, degenerate eyes)."""


def ibug_points(points: Points) -> np.ndarray:
    """The ``ibug68`` set of a message as a (68, 2) array, or raise :class:`FeatureError`."""
    for point_set in points.sets:
        if point_set.scheme == IBUG68:
            if point_set.dims not in (2, 3) or len(point_set.coords) != N_IBUG * point_set.dims:
                raise FeatureError(f"ibug68 set has {len(point_set.coords)} values")
            array = np.asarray(point_set.coords, dtype=np.float64)
            return array.reshape(N_IBUG, point_set.dims)[:, :2]
    schemes = ", ".join(s.scheme for s in points.sets) or "none"
    raise FeatureError(f"no ibug68 point set in the message (has: {schemes})")


def normalise(points: np.ndarray) -> np.ndarray:
    """Points in the eye-corner face frame: translation, rotation and scale removed."""
    right, left = points[RIGHT_EYE_OUTER], points[LEFT_EYE_OUTER]
    axis = left - right
    iod = float(np.hypot(axis[0], axis[1]))
    if not np.isfinite(iod) or iod < MIN_IOD_PX:
        raise FeatureError(f"outer eye corners are {iod:.3g} px apart: no face frame")
    cos, sin = axis / iod
    rotation = np.array([[cos, sin], [-sin, cos]])
    return ((points - (right + left) / 2.0) @ rotation.T) / iod


def nose_distances(normalised: np.ndarray) -> np.ndarray:
    """Distance of every point to the nose tip (the paper's 68 features), in IOD units."""
    offsets = normalised - normalised[NOSE_TIP]
    return np.hypot(offsets[:, 0], offsets[:, 1])


class NeutralEstimator:
    """The neutral face as the median of features over the first ``seconds`` with a face."""

    def __init__(self, seconds: float = 1.0) -> None:
        if not seconds > 0:
            raise ValueError("the neutral window must be longer than zero seconds")
        self.window_ns = int(seconds * 1e9)
        self._start_ns: int | None = None
        self._samples: list[np.ndarray] = []
        self.neutral: np.ndarray | None = None

    @property
    def ready(self) -> bool:
        """Whether the neutral is known."""
        return self.neutral is not None

    def add(self, t_media_ns: int, values: np.ndarray) -> bool:
        """Add one face frame's features; return whether the neutral is now known."""
        if self.neutral is not None:
            return True
        if self._start_ns is None:
            self._start_ns = t_media_ns
        if t_media_ns - self._start_ns < self.window_ns or not self._samples:
            self._samples.append(values.copy())
            return False
        self.neutral = np.median(np.stack(self._samples), axis=0)
        self._samples.clear()
        return True


class FeatureProcessor:
    """Points messages in, Features messages out."""

    def __init__(self, neutral: np.ndarray | None = None, neutral_seconds: float = 1.0) -> None:
        self.estimator = NeutralEstimator(neutral_seconds)
        if neutral is not None:
            if neutral.shape != (N_IBUG,) or not np.all(np.isfinite(neutral)):
                raise FeatureError("a neutral needs 68 finite distances")
            self.estimator.neutral = neutral.astype(np.float64)

    def process(self, points: Points) -> Features:
        """Features of one frame; raise :class:`FeatureError` for unusable points."""
        if not points.face:
            return Features(
                seq=points.seq,
                t_capture_ns=points.t_capture_ns,
                t_media_ns=points.t_media_ns,
                face=False,
                neutral_ready=self.estimator.ready,
            )
        distances = nose_distances(normalise(ibug_points(points)))
        ready = self.estimator.add(points.t_media_ns, distances)
        neutral = self.estimator.neutral
        deltas = (distances - neutral).tolist() if ready and neutral is not None else []
        return Features(
            seq=points.seq,
            t_capture_ns=points.t_capture_ns,
            t_media_ns=points.t_media_ns,
            face=True,
            neutral_ready=ready,
            distances=distances.tolist(),
            deltas=deltas,
        )
