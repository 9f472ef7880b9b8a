"""Points backends, one module each, registered in :data:`~.registry.BACKENDS`: the face
tracker (default), and replays of OpenFace CSV and facesynth track files."""

from facesynth.services.points.backends.base import (
    BackendError,
    PointsBackend,
    face_points,
    no_face,
    point_set,
)

__all__ = ["BackendError", "PointsBackend", "face_points", "no_face", "point_set"]
