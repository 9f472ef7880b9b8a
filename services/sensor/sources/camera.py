"""A live camera with a one-frame buffer, timed by the wall clock."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Annotated

import msgspec
import numpy as np

from services.sensor.sources.base import FrameSource, SourceError, SourceInfo, opencv
from services.sensor.sources.registry import SOURCES


class CameraConfig(
    msgspec.Struct, tag="camera", tag_field="source", kw_only=True, forbid_unknown_fields=True
):
    """A live camera (one-frame buffer)."""

    index: Annotated[
        int,
        msgspec.Meta(ge=0, description="camera index", extra={"flag": "--camera", "selects": True}),
    ] = 0
    fps: Annotated[float, msgspec.Meta(gt=0, le=1000, description="frame rate override")] | None = (
        None
    )
    width: Annotated[int, msgspec.Meta(ge=0, description="camera: requested width")] = 0
    height: Annotated[int, msgspec.Meta(ge=0, description="camera: requested height")] = 0


@SOURCES.register(CameraConfig)
class CameraSource(FrameSource):
    """A live camera with a one-frame buffer, timed by the wall clock."""

    def __init__(self, config: CameraConfig) -> None:
        index, width, height, fps = config.index, config.width, config.height, config.fps or 0.0
        cv2 = opencv()
        self._capture = cv2.VideoCapture(index)
        if not self._capture.isOpened():
            raise SourceError(f"cannot open camera {index}")
        self._capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)
        if width and height:
            self._capture.set(cv2.CAP_PROP_FRAME_WIDTH, width)
            self._capture.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        if fps:
            self._capture.set(cv2.CAP_PROP_FPS, fps)
        rate = float(self._capture.get(cv2.CAP_PROP_FPS) or fps or 30.0)
        self.info = SourceInfo(f"camera:{index}", rate, None, live=True)

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        start = time.monotonic_ns()
        while True:
            ok, image = self._capture.read()
            if not ok:
                raise SourceError(f"{self.info.name}: the camera stopped delivering frames")
            yield image, time.monotonic_ns() - start

    def close(self) -> None:
        self._capture.release()
