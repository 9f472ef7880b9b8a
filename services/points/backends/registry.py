"""The points backend registry: every module of this package that registers a backend.

A backend is one module here: a config struct tagged with its name (``tag_field="backend"``)
and a :class:`~facesynth.services.points.backends.base.PointsBackend` built as ``Backend(config)``.
"""

from __future__ import annotations

from facesynth.runtime.plugins import Registry
from facesynth.services.points.backends.base import PointsBackend

BACKENDS: Registry[PointsBackend] = Registry(
    "backend",
    tag_field="backend",
    package="facesynth.services.points.backends",
    entry_points="facesynth.backends",
)
