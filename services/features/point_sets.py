"""Feature processor F's input: a Points message's sets read as arrays, checked.

The ``ibug68`` points (required), an optional set of a scheme (the ``iris10`` points), the face
mesh's 468 vertices (``mesh468``, or the first 468 of ``mesh478``) and the ``blendshapes52``
scores. A set that is there but malformed raises :class:`FeatureError`, never a wrong array.
"""

from __future__ import annotations

import numpy as np

from facesynth.runtime import blendshapes
from facesynth.runtime.float_lists import float64_array
from facesynth.runtime.landmarks import IBUG68, MESH468, MESH478, N_IBUG
from facesynth.schemas.messages import Points
from facesynth.services.features.frame import FeatureError
from facesynth.services.features.pose import N_MESH

#: Iris points of Face Landmarker v2 after the mesh's 468 vertices (``mesh478``).
N_IRIS = 10


def ibug_points(points: Points) -> np.ndarray:
    """The ``ibug68`` set of a message as a (68, 2) array, or raise :class:`FeatureError`."""
    for point_set in points.sets:
        if point_set.scheme == IBUG68:
            if point_set.dims not in (2, 3) or len(point_set.coords) != N_IBUG * point_set.dims:
                raise FeatureError(f"ibug68 set has {len(point_set.coords)} values")
            array = float64_array(point_set.coords)
            return array.reshape(N_IBUG, point_set.dims)[:, :2]
    schemes = ", ".join(s.scheme for s in points.sets) or "none"
    raise FeatureError(f"no ibug68 point set in the message (has: {schemes})")


def optional_points(points: Points, scheme: str, count: int, dims: int) -> np.ndarray | None:
    """A point set as a (count, dims) array; None if absent or without ``dims`` dimensions.

    A set with the wrong number of values raises :class:`FeatureError`. A ``mesh468`` with 2
    dimensions (no depth) is of no use for pose and counts as absent.
    """
    for point_set in points.sets:
        if point_set.scheme == scheme:
            if point_set.dims < dims:
                return None
            if len(point_set.coords) != count * point_set.dims:
                raise FeatureError(f"{scheme} set has {len(point_set.coords)} values")
            array = float64_array(point_set.coords)
            if not np.isfinite(array).all():
                raise FeatureError(f"{scheme} set has a value that is not a finite number")
            return array.reshape(count, point_set.dims)[:, :dims]
    return None


def mesh_points(points: Points) -> np.ndarray | None:
    """The face mesh's 468 vertices (468, 3): the ``mesh468`` set, else the first 468 points of
    a ``mesh478`` set (Face Landmarker v2: the same vertices, then the irises); None if neither
    (or only without depth). A set with the wrong number of values raises :class:`FeatureError`.
    """
    mesh = optional_points(points, MESH468, N_MESH, 3)
    if mesh is None:
        full = optional_points(points, MESH478, N_MESH + N_IRIS, 3)
        if full is not None:
            mesh = full[:N_MESH]
    return mesh


def blendshape_scores(points: Points) -> np.ndarray | None:
    """The ``blendshapes52`` scores of a message (52 in MediaPipe's order), or None if absent.

    A set with the wrong number of values, or values that are not finite numbers in [0, 1],
    raises :class:`FeatureError`.
    """
    for score_set in points.scores:
        if score_set.scheme == blendshapes.BLENDSHAPES52:
            values = float64_array(score_set.values)
            if values.shape != (blendshapes.COUNT,):
                raise FeatureError(f"blendshapes52 set has {values.size} values")
            # NaN fails both comparisons, an infinity one: finite numbers in 0..1 pass
            if not ((values >= 0.0) & (values <= 1.0)).all():
                raise FeatureError("blendshapes52 set has a value that is not a number in 0..1")
            return values
    return None


def blendshape_features(scores: np.ndarray | None) -> dict[str, float]:
    """The absolute raw values of the blendshape features (``_neutral`` left out)."""
    if scores is None:
        return {}
    return dict(zip(blendshapes.SHAPES, scores[1:].tolist(), strict=True))
