"""The points backend seam: each backend turns one Frame into one Points message.

Replays (OpenFace CSV, facesynth's own track files) pick the recorded landmarks of the frame
with the same sequence number and ignore the pixels, so a replay runs through the same chain,
with the same timing and latency measurements, as live tracking. Past the end of a recording
(without ``loop``) every frame is "no face".
"""

from __future__ import annotations

import abc
from typing import ClassVar

import numpy as np

from facesynth.schemas.messages import Frame, Points, PointSet, ScoreSet


class BackendError(ValueError):
    """A backend that cannot be set up (unreadable recording, missing model)."""


def face_points(
    frame: Frame,
    sets: list[PointSet],
    confidence: float,
    source: str,
    scores: list[ScoreSet] | None = None,
) -> Points:
    """A "face present" Points message for ``frame`` (with ``scores``, e.g. blendshapes)."""
    return _points(frame, True, sets, confidence, source, scores or [])


def no_face(frame: Frame, source: str, confidence: float = 0.0) -> Points:
    """A "no face" Points message for ``frame`` (never stale points)."""
    return _points(frame, False, [], confidence, source, [])


def _points(
    frame: Frame,
    face: bool,
    sets: list[PointSet],
    confidence: float,
    source: str,
    scores: list[ScoreSet],
) -> Points:
    return Points(
        seq=frame.seq,
        t_capture_ns=frame.t_capture_ns,
        t_media_ns=frame.t_media_ns,
        face=face,
        confidence=confidence,
        image_width=frame.width,
        image_height=frame.height,
        sets=sets,
        scores=scores,
        source=source,
        capture_host=frame.capture_host,
    )


def point_set(scheme: str, array: np.ndarray) -> PointSet:
    """A PointSet from an (N, 2) or (N, 3) array."""
    return PointSet(
        scheme=scheme, dims=int(array.shape[1]), coords=array.astype(float).ravel().tolist()
    )


class PointsBackend(abc.ABC):
    """Frames in, Points out."""

    name: str = "backend"
    #: The ``facesynth`` extra whose packages it imports when built (``facesynth doctor`` checks
    #: that a graph's plugins have theirs); None: no extra.
    needs_extra: ClassVar[str | None] = None

    @abc.abstractmethod
    def process(self, frame: Frame) -> Points:
        """Landmarks of one frame (or "no face")."""

    def frame_count(self) -> int | None:
        """How many frames a recording holds (``None`` for live trackers)."""
        return None

    def gives_blendshapes(self) -> bool:
        """Whether its Points carry the ``blendshapes52`` scores (profiles may need them)."""
        return False

    def needs_pixels(self) -> bool:
        """Whether frames must carry an image."""
        return False


class Replay(PointsBackend):
    """A recording answering frame ``n`` with its ``n``-th entry (``loop``: modulo its length)."""

    def __init__(self, loop: bool) -> None:
        self.loop = loop

    def _index(self, seq: int, length: int) -> int | None:
        if self.loop:
            return seq % length
        return seq if seq < length else None
