"""A live camera with a one-frame buffer, timed by the wall clock.

``--camera`` (the ``index`` field) takes what OpenCV opens: a device index (``0``), a V4L2
device path (``/dev/video2``, ``/dev/v4l/by-id/…``), or a stream URL (an IP or phone camera,
``facesynth simhead``'s ``http://127.0.0.1:8090/camera.mjpg``, ``rtsp://…``), opened through
FFmpeg with open and read timeouts. :func:`camera_target` checks it first, so a mistake is one
line in our words.

A camera that already sends JPEGs has them passed through (``--passthrough``, on by default;
:func:`capture_mode` chooses): an ``http(s)://`` MJPEG stream is read as its JPEG parts
(:mod:`.mjpeg`), and a device is asked for its MJPG format with OpenCV's RGB conversion off, so
``read()`` returns the JPEG buffer (:func:`device_frame`). Either falls back to decoding when
the camera does not give JPEGs (a URL that is not MJPEG goes to FFmpeg; a device or back end
that gives pixels is decoded as before). ``--width``/``--height`` on a URL ask for pixels:
the decode path.

An MJPEG URL sends every frame, whether the reader keeps up or not: ``--newest-frame``
(:mod:`.newest`; ``facesynth learn`` turns it on for the robot's camera) reads it in a thread
and passes on only the newest frame, stamped when it arrived, so a slow chain never takes a
frame that waited in the socket as a new one.
"""

from __future__ import annotations

import logging
import os
import stat
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Final, Literal

import msgspec
import numpy as np

from facesynth.runtime.jpeg import JpegHeaderError
from facesynth.services.sensor.sources.base import (
    FrameSource,
    Image,
    JpegImage,
    SourceError,
    SourceInfo,
    opencv,
)
from facesynth.services.sensor.sources.mjpeg import MjpegStream, NotMjpeg, part_image
from facesynth.services.sensor.sources.newest import NewestFrame
from facesynth.services.sensor.sources.registry import SOURCES

log = logging.getLogger(__name__)

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
    passthrough: Annotated[
        bool,
        msgspec.Meta(
            description="camera: send the camera's own JPEGs as they are when it gives JPEGs "
            "(an MJPEG URL, a device's MJPG format; default on)"
        ),
    ] = True
    newest: Annotated[
        bool,
        msgspec.Meta(
            description="camera: an MJPEG URL read in a thread of its own, only its newest "
            "frame kept, stamped when it arrived (frames not taken in time are dropped, not "
            "queued; facesynth learn turns it on; default off)",
            extra={"flag": "--newest-frame"},
        ),
    ] = False


#: How a camera's frames reach the bus: MJPEG parts over HTTP as they are, a device's MJPG
#: buffers as they are, or decoded pixels (encoded again by the sensor).
CaptureMode = Literal["mjpeg-url", "device-mjpg", "decode"]
#: The MJPG FOURCC code as OpenCV reports it (``cv2.VideoWriter_fourcc(*"MJPG")``).
MJPG_FOURCC: Final = ord("M") | ord("J") << 8 | ord("P") << 16 | ord("G") << 24


def capture_mode(target: int | str, *, passthrough: bool, width: int, height: int) -> CaptureMode:
    """How to read the camera ``target`` (from :func:`camera_target`).

    Passthrough applies when it is on and no pixel change is asked: an ``http(s)`` URL without
    ``--width``/``--height`` is read as MJPEG (it falls back to FFmpeg if it is not); a device
    is asked for MJPG (its size is a request to the device, not a resize). Other URLs (rtsp,
    …) are decoded by FFmpeg.
    """
    if not passthrough:
        return "decode"
    if isinstance(target, str) and "://" in target:
        scheme = target.partition("://")[0].lower()
        if scheme in ("http", "https") and not (width or height):
            return "mjpeg-url"
        return "decode"
    return "device-mjpg"


def device_frame(buffer: np.ndarray | None) -> Image:
    """What a device's ``read()`` gave with RGB conversion off: its JPEG, or its pixels.

    A one-row (or flat) uint8 buffer holding a JPEG is a :class:`JpegImage`; an HxWx3 image
    (the back end decoded anyway) is the pixels; anything else (an empty or broken buffer, a
    raw YUV frame) is ``None``: not usable as it is.
    """
    if buffer is None or buffer.dtype != np.uint8 or buffer.size == 0:
        return None
    if buffer.ndim == 3 and buffer.shape[2] == 3:
        return buffer
    if buffer.ndim == 1 or (buffer.ndim == 2 and buffer.shape[0] == 1):
        try:
            return part_image(buffer.tobytes())
        except JpegHeaderError:
            return None
    return None


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
        self.mode = capture_mode(target, passthrough=config.passthrough, width=width, height=height)
        self.dropped = 0
        self._stream: MjpegStream | None = None
        self._newest: NewestFrame[JpegImage] | None = None
        self._newest_on = config.newest
        self._captured_ns: int | None = None
        if self.mode == "mjpeg-url":
            assert isinstance(target, str)
            try:
                self._stream = MjpegStream(target, STREAM_TIMEOUT_MS / 1000)
            except NotMjpeg:
                self.mode = "decode"  # not MJPEG: FFmpeg reads what it is
            else:
                self.info = SourceInfo(f"camera:{target}", fps or 30.0, None, live=True)
                return
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
        if self.mode == "device-mjpg":
            # The format first (V4L2 picks sizes per format), then no conversion: read() then
            # returns the JPEG buffer. A device or back end without MJPG: decode as before.
            self._capture.set(cv2.CAP_PROP_FOURCC, MJPG_FOURCC)
            if int(self._capture.get(cv2.CAP_PROP_FOURCC)) == MJPG_FOURCC:
                self._capture.set(cv2.CAP_PROP_CONVERT_RGB, 0)
            else:
                self.mode = "decode"
        if width and height:
            self._capture.set(cv2.CAP_PROP_FRAME_WIDTH, width)
            self._capture.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        if fps:
            self._capture.set(cv2.CAP_PROP_FPS, fps)
        rate = float(self._capture.get(cv2.CAP_PROP_FPS) or fps or 30.0)
        if not 0 < rate <= 1000:  # a stream may not say (FFmpeg then reports a guess)
            rate = fps or 30.0
        self.info = SourceInfo(f"camera:{target}", rate, None, live=True)

    def frames(self) -> Iterator[tuple[Image, int]]:
        start = time.monotonic_ns()
        if self._stream is not None and self._newest_on:
            self._newest = NewestFrame(self._stream.images(), name=self.info.name)
            for arrived in self._newest:
                self._captured_ns = arrived.wall_ns
                yield arrived.frame, arrived.monotonic_ns - start
            return
        if self._stream is not None:
            for jpeg in self._stream.images():
                yield jpeg, time.monotonic_ns() - start
            return
        while True:
            ok, buffer = self._capture.read()
            if not ok:
                raise SourceError(f"{self.info.name}: the camera stopped delivering frames")
            image: Image = buffer
            if self.mode == "device-mjpg":
                image = device_frame(buffer)
                if image is None:
                    self._not_jpeg()
                    continue
            yield image, time.monotonic_ns() - start

    def _not_jpeg(self) -> None:
        """A device buffer that is not a JPEG: dropped, and conversion back on (decode path)."""
        self.dropped += 1
        log.warning("%s: the device gives no JPEG buffers: decoding frames", self.info.name)
        self._capture.set(opencv().CAP_PROP_CONVERT_RGB, 1)
        self.mode = "decode"

    def capture_time_ns(self) -> int | None:
        """With ``newest``, when the frame yielded last arrived (wall clock): the sensor's
        stamp would be when it was taken, after any wait on the chain."""
        return self._captured_ns

    @property
    def stale_dropped(self) -> int:
        """With ``newest``, frames dropped because a newer one arrived before they were taken."""
        return self._newest.dropped if self._newest is not None else 0

    @property
    def parts_dropped(self) -> int:
        """Frames dropped because they were not JPEGs (stream parts or device buffers)."""
        return self.dropped + (self._stream.dropped if self._stream is not None else 0)

    def close(self) -> None:
        if self._stream is not None:
            self._stream.close()
            if self._newest is not None:
                self._newest.join(1.0)  # its read ends with the stream
        else:
            self._capture.release()
