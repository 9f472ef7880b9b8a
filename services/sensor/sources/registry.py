"""The frame source registry: every module of this package that registers a source.

A source is one module here: a config struct tagged with its name (``tag_field="source"``)
and a :class:`~facesynth.services.sensor.sources.base.FrameSource` built as ``Source(config)``.
"""

from __future__ import annotations

from facesynth.runtime.plugins import Registry
from facesynth.services.sensor.sources.base import FrameSource

SOURCES: Registry[FrameSource] = Registry(
    "source",
    tag_field="source",
    package="facesynth.services.sensor.sources",
    entry_points="facesynth.sources",
)
