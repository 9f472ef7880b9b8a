"""Replay of a ``facesynth track`` JSON-lines file (mesh, iris and 68-point views, and the
blendshapes when the file has them)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import msgspec
import numpy as np

from facesynth.runtime import blendshapes
from facesynth.runtime.codec import MAX_COORD
from facesynth.runtime.landmarks import IBUG68, IRIS10, MESH468, N_IBUG
from facesynth.schemas.messages import Frame, Points, PointSet, ScoreSet
from facesynth.services.points.backends.base import (
    BackendError,
    Replay,
    face_points,
    no_face,
    point_set,
)
from facesynth.services.points.backends.registry import BACKENDS
from facesynth.services.points.track_file import TrackLine


class TrackFileConfig(
    msgspec.Struct, tag="track", tag_field="backend", kw_only=True, forbid_unknown_fields=True
):
    """Replay a facesynth track file."""

    path: Annotated[
        str,
        msgspec.Meta(
            description="replay a facesynth track file",
            extra={"flag": "--points-jsonl", "selects": True},
        ),
    ]
    loop: Annotated[
        bool,
        msgspec.Meta(
            description="loop the replayed points instead of reporting no face past their end",
            extra={"flag": "--loop-replay"},
        ),
    ] = False


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


def _track_scores(line: TrackLine, where: str) -> list[ScoreSet]:
    if line.blendshapes is None:
        return []
    values = np.asarray(line.blendshapes, dtype=np.float64)
    if (
        values.shape != (blendshapes.COUNT,)
        or not np.all(np.isfinite(values))
        or values.min() < 0.0
        or values.max() > 1.0
    ):
        raise BackendError(f"{where}: blendshapes must be {blendshapes.COUNT} numbers in 0..1")
    return [ScoreSet(scheme=blendshapes.BLENDSHAPES52, values=values.tolist())]


@BACKENDS.register(TrackFileConfig)
class TrackReplay(Replay):
    """Replay of a ``facesynth track`` JSON-lines file (mesh, iris and 68-point views, and the
    blendshapes when the file has them)."""

    name = "track"

    def __init__(self, config: TrackFileConfig) -> None:
        super().__init__(config.loop)
        file = Path(config.path)
        decoder = msgspec.json.Decoder(TrackLine)
        self.lines: list[tuple[bool, float, list[PointSet], list[ScoreSet]]] = []
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
            scores = _track_scores(line, where) if line.face else []
            self.lines.append((line.face, line.presence, sets, scores))
        if not self.lines:
            raise BackendError(f"{file}: no frames")

    def frame_count(self) -> int:
        return len(self.lines)

    def gives_blendshapes(self) -> bool:
        return any(scores for _, _, _, scores in self.lines)

    def process(self, frame: Frame) -> Points:
        index = self._index(frame.seq, len(self.lines))
        if index is None:
            return no_face(frame, self.name)
        face, presence, sets, scores = self.lines[index]
        if not face:
            return no_face(frame, self.name, presence)
        return face_points(frame, sets, presence, self.name, list(scores))
