"""Replay of OpenFace 2 ``FeatureExtraction`` CSV output (68 landmarks per frame)."""

from __future__ import annotations

from typing import Annotated

import msgspec

from facesynth.runtime.landmarks import IBUG68
from facesynth.schemas.messages import Frame, Points
from facesynth.services.points.backends.base import Replay, face_points, no_face, point_set
from facesynth.services.points.backends.registry import BACKENDS
from facesynth.services.points.openface_csv import OpenFaceRow, load_openface_csv


class OpenFaceConfig(
    msgspec.Struct, tag="openface", tag_field="backend", kw_only=True, forbid_unknown_fields=True
):
    """Replay OpenFace 2 CSV landmarks."""

    csv: Annotated[
        str,
        msgspec.Meta(
            description="replay OpenFace 2 CSV landmarks (row n answers frame n)",
            extra={"flag": "--openface-csv", "selects": True},
        ),
    ]
    loop: Annotated[
        bool,
        msgspec.Meta(
            description="loop the replayed points instead of reporting no face past their end",
            extra={"flag": "--loop-replay"},
        ),
    ] = False


@BACKENDS.register(OpenFaceConfig)
class OpenFaceReplay(Replay):
    """Replay of OpenFace 2 CSV output: row ``n`` (in frame order) answers frame ``n``."""

    name = "openface"

    def __init__(self, config: OpenFaceConfig) -> None:
        super().__init__(config.loop)
        self.rows: list[OpenFaceRow] = load_openface_csv(config.csv)

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
