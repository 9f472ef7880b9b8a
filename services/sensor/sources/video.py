"""A video file, timed by frame index and the file's frame rate."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import msgspec
import numpy as np

from facesynth.services.sensor.sources.base import FrameSource, SourceError, SourceInfo, opencv
from facesynth.services.sensor.sources.registry import SOURCES


class VideoConfig(
    msgspec.Struct, tag="video", tag_field="source", kw_only=True, forbid_unknown_fields=True
):
    """A video file (default: the bundled performer video)."""

    path: (
        Annotated[
            str,
            msgspec.Meta(
                description="video file (default: the bundled performer video)",
                extra={"flag": "--video", "selects": True},
            ),
        ]
        | None
    ) = None
    loop: Annotated[bool, msgspec.Meta(description="loop the video or image folder")] = False
    fps: Annotated[float, msgspec.Meta(gt=0, le=1000, description="frame rate override")] | None = (
        None
    )


#: Videos up to this many pixels a frame (720p) are decoded on one thread.
ONE_THREAD_PIXELS = 1280 * 720


@SOURCES.register(VideoConfig)
class VideoSource(FrameSource):
    """Frames of a video file, timed by their index and the file's frame rate."""

    needs_extra = "tracker"

    def __init__(self, config: VideoConfig) -> None:
        if config.path is None:
            raise SourceError("a video source needs a path (--video PATH)")
        cv2 = opencv()
        self.path = Path(config.path)
        loop, fps = config.loop, config.fps
        if not self.path.is_file():
            raise SourceError(f"video {self.path} does not exist")
        self.loop = loop
        self._capture = cv2.VideoCapture(str(self.path))
        if not self._capture.isOpened():
            raise SourceError(f"cannot open {self.path} as a video")
        pixels = self._capture.get(cv2.CAP_PROP_FRAME_WIDTH) * self._capture.get(
            cv2.CAP_PROP_FRAME_HEIGHT
        )
        if 0 < pixels <= ONE_THREAD_PIXELS:
            # One decoding thread: FFmpeg's default (a thread per core, frames handed between
            # them) costs more CPU per frame for a small video, and decodes it fast enough.
            single = cv2.VideoCapture(str(self.path), cv2.CAP_FFMPEG, [cv2.CAP_PROP_N_THREADS, 1])
            if single.isOpened():
                self._capture.release()
                self._capture = single
        rate = fps or float(self._capture.get(cv2.CAP_PROP_FPS) or 0.0)
        if not rate > 0 or rate > 1000:
            rate = 30.0
        count = int(self._capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
        self.info = SourceInfo(str(self.path), rate, count or None, live=False)

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        """Every frame, timed by its index; a file that stops decoding before the frame count
        its container announces (truncated or corrupt) raises :class:`SourceError` saying how
        many frames were read, once they have been yielded."""
        cv2 = opencv()
        period_ns = 1e9 / self.info.fps
        index = 0
        in_pass = 0
        while True:
            ok, image = self._capture.read()
            if not ok:
                if index == 0:
                    raise SourceError(f"{self.path}: no frame could be decoded")
                self._check_complete(in_pass)
                if not self.loop:
                    return
                self._capture.set(cv2.CAP_PROP_POS_FRAMES, 0)
                in_pass = 0
                ok, image = self._capture.read()
                if not ok:
                    return
            yield image, round(index * period_ns)
            index += 1
            in_pass += 1

    def _check_complete(self, read: int) -> None:
        expected = self.info.frames
        if expected is not None and read < expected:
            raise SourceError(
                f"video truncated or corrupt: decoded {read} of {expected} frames from {self.path}"
            )

    def close(self) -> None:
        self._capture.release()
