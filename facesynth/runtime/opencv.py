"""OpenCV, imported only where images are handled: hosts without it still run the rest."""

from __future__ import annotations

from types import ModuleType


def import_cv2(error: type[Exception]) -> ModuleType:
    """The ``cv2`` module; raises ``error`` with a one-line hint when OpenCV is not installed."""
    try:
        import cv2
    except ImportError:
        raise error(
            "OpenCV is not installed: install facesynth[tracker] on hosts that handle images"
        ) from None
    return cv2
