"""A live camera with a one-frame buffer, timed by the wall clock.

``--camera`` (the ``index`` field) takes what OpenCV opens: a device index (``0``), a V4L2
device path (``/dev/video2``, ``/dev/v4l/by-id/…``), or a stream URL (an IP or phone camera,
``facesynth simhead``'s ``http://127.0.0.1:8090/camera.mjpg``, ``rtsp://…``), opened through
FFmpeg with open and read timeouts. :func:`camera_target` checks it first, so a mistake is one
line in our words.
"""

from __future__ import annotations

import os
import stat
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Final

import msgspec
import numpy as np

from services.sensor.sources.base import FrameSource, SourceError, SourceInfo, opencv
from services.sensor.sources.registry import SOURCES

#: URL schemes OpenCV's FFmpeg back end opens as live streams.
STREAM_SCHEMES: Final = ("http", "https", "rtsp", "rtsps", "rtmp", "udp", "tcp", "srt")
#: How long opening a stream and reading one frame may take.
STREAM_TIMEOUT_MS: Final = 10_000
WHAT: Final = "a device index (0), a /dev/video* path or a stream URL (http://…, rtsp://…)"


class CameraConfig(
    msgspec.Struct, tag="camera", tag_field="source", kw_only=True, forbid_unknown_fields=True
):
    """A live camera (one-frame buffer): a device index, a device path or a stream URL."""

    index: Annotated[
        Annotated[int, msgspec.Meta(ge=0)] | str,
        msgspec.Meta(
            description=WHAT,
            extra={"flag": "--camera", "selects": True},
        ),
    ] = 0
    fps: Annotated[float, msgspec.Meta(gt=0, le=1000, description="frame rate override")] | None = (
        None
    )
    width: Annotated[int, msgspec.Meta(ge=0, description="camera: requested width")] = 0
    height: Annotated[int, msgspec.Meta(ge=0, description="camera: requested height")] = 0


def camera_target(value: int | str) -> int | str:
    """What to open for ``--camera value``: an index (int), a device path or a stream URL.

    Raises:
        SourceError: a negative index, a path that does not exist or is a file (use
            ``--video``), a URL scheme OpenCV does not stream, or anything else.
    """
    if isinstance(value, int):
        if value < 0:
            raise SourceError(f"--camera {value}: a device index is 0 or more")
        return value
    text = value.strip()
    if text.isdigit():
        return int(text)
    if text.startswith("-") and text[1:].isdigit():
        raise SourceError(f"--camera {text}: a device index is 0 or more")
    scheme, sep, rest = text.partition("://")
    if sep:
        if scheme.lower() not in STREAM_SCHEMES:
            raise SourceError(
                f"--camera {text}: cannot stream {scheme}:// (known: "
                f"{', '.join(s + '://' for s in STREAM_SCHEMES)})"
            )
        if not rest or rest.startswith("/"):
            raise SourceError(f"--camera {text}: the URL has no host")
        return text
    if "/" in text:
        path = Path(text)
        try:
            mode = os.stat(path).st_mode
        except FileNotFoundError:
            raise SourceError(f"--camera {text}: no such device") from None
        except OSError as exc:
            raise SourceError(f"--camera {text}: {exc.strerror}") from None
        if stat.S_ISREG(mode):
            raise SourceError(f"--camera {text}: a file, not a camera (use --video for files)")
        if not stat.S_ISCHR(mode):
            raise SourceError(f"--camera {text}: not a camera device")
        return text
    raise SourceError(f"--camera {text!r}: expected {WHAT}")


@SOURCES.register(CameraConfig)
class CameraSource(FrameSource):
    """A live camera with a one-frame buffer, timed by the wall clock."""

    needs_extra = "tracker"

    def __init__(self, config: CameraConfig) -> None:
        target = camera_target(config.index)
        width, height, fps = config.width, config.height, config.fps or 0.0
        cv2 = opencv()
        if isinstance(target, str) and "://" in target:
            timeouts = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, STREAM_TIMEOUT_MS]
            timeouts += [cv2.CAP_PROP_READ_TIMEOUT_MSEC, STREAM_TIMEOUT_MS]
            self._capture = cv2.VideoCapture(target, cv2.CAP_FFMPEG, timeouts)
            if not self._capture.isOpened():
                raise SourceError(
                    f"cannot open the camera stream {target} (nothing streams there?)"
                )
        else:
            self._capture = cv2.VideoCapture(target)
            if not self._capture.isOpened():
                raise SourceError(f"cannot open camera {target}")
        self._capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)
        if width and height:
            self._capture.set(cv2.CAP_PROP_FRAME_WIDTH, width)
            self._capture.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        if fps:
            self._capture.set(cv2.CAP_PROP_FPS, fps)
        rate = float(self._capture.get(cv2.CAP_PROP_FPS) or fps or 30.0)
        if not 0 < rate <= 1000:  # a stream may not say (FFmpeg then reports a guess)
            rate = fps or 30.0
        self.info = SourceInfo(f"camera:{target}", rate, None, live=True)

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        start = time.monotonic_ns()
        while True:
            ok, image = self._capture.read()
            if not ok:
                raise SourceError(f"{self.info.name}: the camera stopped delivering frames")
            yield image, time.monotonic_ns() - start

    def close(self) -> None:
        self._capture.release()
