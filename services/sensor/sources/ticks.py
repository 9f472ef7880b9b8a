"""Frames without pixels at a fixed rate: the clock for replayed point streams."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Annotated

import msgspec
import numpy as np

from facesynth.services.sensor.sources.base import FrameSource, SourceError, SourceInfo
from facesynth.services.sensor.sources.registry import SOURCES


class TicksConfig(
    msgspec.Struct, tag="ticks", tag_field="source", kw_only=True, forbid_unknown_fields=True
):
    """Frames without pixels (the clock for replayed point streams)."""

    count: Annotated[
        int,
        msgspec.Meta(
            ge=1,
            description="N frames without pixels (clock for replays)",
            extra={"flag": "--ticks", "selects": True},
        ),
    ]
    fps: Annotated[float, msgspec.Meta(gt=0, le=1000, description="frame rate override")] | None = (
        None
    )


@SOURCES.register(TicksConfig)
class TickSource(FrameSource):
    """Frames without pixels at a fixed rate: the clock for replayed point streams."""

    def __init__(self, config: TicksConfig) -> None:
        count, fps = config.count, 30.0 if config.fps is None else config.fps
        if count < 1 or not fps > 0:
            raise SourceError("ticks need a positive count and rate")
        self.count = count
        self.info = SourceInfo("ticks", fps, count, live=False)

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        period_ns = 1e9 / self.info.fps
        for index in range(self.count):
            yield None, round(index * period_ns)
