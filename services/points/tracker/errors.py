"""Exceptions raised by the face-tracker engine."""

from __future__ import annotations

__all__ = ["ModelError", "VideoError"]


class ModelError(ValueError):
    """A model file is missing, unreadable, corrupt (wrong checksum) or cannot be loaded."""


class VideoError(ValueError):
    """A video file cannot be opened or decoded completely (missing, corrupt or truncated)."""
