"""Frame sources, one module each, registered in :data:`~.registry.SOURCES`.

Every source yields ``(image or None, t_media_ns)``; ``None`` images are ticks (no pixels).
"""

from facesynth.services.sensor.sources.base import FrameSource, JpegImage, SourceError, SourceInfo

__all__ = ["FrameSource", "JpegImage", "SourceError", "SourceInfo"]
