"""The ``facesynth track`` file: JSON Lines, one :class:`TrackLine` per video frame.

Written by :func:`facesynth.services.points.tracker.offline.track_video` and replayed by
:class:`services.points.backends.TrackReplay`; both use :class:`TrackLine`, so the format is
defined here only. A line, in frame pixels::

    {"frame": 0, "face": true, "mesh": [[x, y], ... 468], "iris": [[x, y], ... 10],
     "ibug68": [[x, y], ... 68], "presence": 0.98}

``mesh``, ``iris`` and ``ibug68`` are null (or absent) on a line without a face; a face line
needs ``ibug68``. Points may carry a third coordinate. ``presence`` is the tracker's face
presence score (0..1; absent: 1). ``blendshapes`` (``full`` tracker model) holds the 52 ARKit
blendshape scores in ``facesynth.runtime.blendshapes.NAMES`` order (absent: none).
"""

from __future__ import annotations

import msgspec

__all__ = ["TrackLine", "encode_line"]


class TrackLine(msgspec.Struct, kw_only=True):
    """One line of a ``facesynth track`` file: one video frame."""

    frame: int
    face: bool
    mesh: list[list[float]] | None = None
    iris: list[list[float]] | None = None
    ibug68: list[list[float]] | None = None
    presence: float = 1.0
    blendshapes: list[float] | None = None


_ENCODER = msgspec.json.Encoder()


def encode_line(line: TrackLine) -> bytes:
    """``line`` as one line of the file (compact JSON and a newline)."""
    return _ENCODER.encode(line) + b"\n"
