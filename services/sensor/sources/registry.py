"""The frame source registry: every module of this package that registers a source.

A source is one module here: a config struct tagged with its name (``tag_field="source"``)
and a :class:`~services.sensor.sources.base.FrameSource` built as ``Source(config)``.
"""

from __future__ import annotations

from facesynth.runtime.plugins import Registry
from services.sensor.sources.base import FrameSource

SOURCES: Registry[FrameSource] = Registry(
    "source",
    tag_field="source",
    package="services.sensor.sources",
    entry_points="facesynth.sources",
)
