"""Point streamer backends: each turns one Frame into one Points message.

Replays (OpenFace CSV, facesynth's own track files) pick the recorded landmarks of the frame
with the same sequence number and ignore the pixels, so a replay runs through the same chain,
with the same timing and latency measurements, as live tracking. Past the end of a recording
(without ``loop``) every frame is "no face".
"""

from __future__ import annotations

import abc
import math
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

from facesynth.runtime.codec import MAX_COORD
from facesynth.runtime.landmarks import IBUG68, IRIS10, MESH468, N_IBUG
from schemas.messages import Frame, Points, PointSet
from services.points.openface import OpenFaceRow, load_openface_csv
from services.points.track_file import TrackLine


class BackendError(ValueError):
    """A backend that cannot be set up (unreadable recording, missing model)."""


def face_points(frame: Frame, sets: list[PointSet], confidence: float, source: str) -> Points:
    """A "face present" Points message for ``frame``."""
    return _points(frame, True, sets, confidence, source)


def no_face(frame: Frame, source: str, confidence: float = 0.0) -> Points:
    """A "no face" Points message for ``frame`` (never stale points)."""
    return _points(frame, False, [], confidence, source)


def _points(
    frame: Frame, face: bool, sets: list[PointSet], confidence: float, source: str
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
        source=source,
    )


def point_set(scheme: str, array: np.ndarray) -> PointSet:
    """A PointSet from an (N, 2) or (N, 3) array."""
    return PointSet(
        scheme=scheme, dims=int(array.shape[1]), coords=array.astype(float).ravel().tolist()
    )


class PointsBackend(abc.ABC):
    """Frames in, Points out."""

    name: str = "backend"

    @abc.abstractmethod
    def process(self, frame: Frame) -> Points:
        """Landmarks of one frame (or "no face")."""

    def frame_count(self) -> int | None:
        """How many frames a recording holds (``None`` for live trackers)."""
        return None

    def needs_pixels(self) -> bool:
        """Whether frames must carry an image."""
        return False


class _Replay(PointsBackend):
    def __init__(self, loop: bool) -> None:
        self.loop = loop

    def _index(self, seq: int, length: int) -> int | None:
        if self.loop:
            return seq % length
        return seq if seq < length else None


class OpenFaceReplay(_Replay):
    """Replay of OpenFace 2 CSV output: row ``n`` (in frame order) answers frame ``n``."""

    name = "openface"

    def __init__(self, path: str | Path, *, loop: bool = False) -> None:
        super().__init__(loop)
        self.rows: list[OpenFaceRow] = load_openface_csv(path)

    def frame_count(self) -> int:
        return len(self.rows)

    def process(self, frame: Frame) -> Points:
        index = self._index(frame.seq, len(self.rows))
        if index is None:
            return no_face(frame, self.name)
        row = self.rows[index]
        if not row.success:
            return no_face(frame, self.name, row.confidence)
        return face_points(frame, [point_set(IBUG68, row.points)], row.confidence, self.name)


_SHAPES = ((IBUG68, "ibug68", N_IBUG), (MESH468, "mesh", 468), (IRIS10, "iris", 10))


def _track_sets(line: TrackLine, where: str) -> list[PointSet]:
    sets = []
    for scheme, attr, count in _SHAPES:
        value: Any = getattr(line, attr)
        if value is None:
            continue
        problem = f"{where}: {attr} must be {count} finite [x, y] points within ±{MAX_COORD:g}"
        try:
            array = np.asarray(value, dtype=np.float64)
        except ValueError:  # ragged lists
            raise BackendError(problem) from None
        if (
            array.shape not in ((count, 2), (count, 3))
            or not np.all(np.isfinite(array))
            or np.any(np.abs(array) > MAX_COORD)
        ):
            raise BackendError(problem)
        sets.append(point_set(scheme, array))
    if not any(s.scheme == IBUG68 for s in sets):
        raise BackendError(f"{where}: a face line needs ibug68 points")
    return sets


class TrackReplay(_Replay):
    """Replay of a ``facesynth track`` JSON-lines file (mesh, iris and 68-point views)."""

    name = "track"

    def __init__(self, path: str | Path, *, loop: bool = False) -> None:
        super().__init__(loop)
        file = Path(path)
        decoder = msgspec.json.Decoder(TrackLine)
        self.lines: list[tuple[bool, float, list[PointSet]]] = []
        try:
            raw_lines = file.read_bytes().splitlines()
        except OSError as exc:
            raise BackendError(f"cannot read {file}: {exc}") from None
        for number, raw in enumerate(raw_lines, start=1):
            if not raw.strip():
                continue
            where = f"{file}:{number}"
            try:
                line = decoder.decode(raw)
            except (msgspec.DecodeError, msgspec.ValidationError) as exc:
                raise BackendError(f"{where}: {exc}") from None
            if not (math.isfinite(line.presence) and 0.0 <= line.presence <= 1.0):
                raise BackendError(f"{where}: presence {line.presence} is not within 0..1")
            sets = _track_sets(line, where) if line.face else []
            self.lines.append((line.face, line.presence, sets))
        if not self.lines:
            raise BackendError(f"{file}: no frames")

    def frame_count(self) -> int:
        return len(self.lines)

    def process(self, frame: Frame) -> Points:
        index = self._index(frame.seq, len(self.lines))
        if index is None:
            return no_face(frame, self.name)
        face, presence, sets = self.lines[index]
        if not face:
            return no_face(frame, self.name, presence)
        return face_points(frame, sets, presence, self.name)
