"""The frame source seam: where frames come from, and what every source tells about itself.

Every source yields ``(image, t_media_ns)``: BGR pixels, a camera's own JPEG
(:class:`JpegImage`, sent on as is), or ``None`` for a tick (no pixels).
"""

from __future__ import annotations

import abc
from collections.abc import Iterator
from dataclasses import dataclass
from types import ModuleType
from typing import ClassVar, overload

import numpy as np

from facesynth.runtime.opencv import import_cv2


class SourceError(ValueError):
    """A source that cannot be opened or read (missing file, not a video, no camera)."""


@dataclass(frozen=True)
class JpegImage:
    """A frame a camera delivered already JPEG-encoded, passed on as its bytes.

    ``width`` and ``height`` come from the JPEG's frame header
    (:func:`facesynth.runtime.jpeg.jpeg_size`), not from decoding it.
    """

    data: bytes
    width: int
    height: int


#: What a source yields as a frame's image: pixels (BGR), a camera's JPEG, or none (a tick).
Image = np.ndarray | JpegImage | None


@dataclass
class SourceInfo:
    """What a source is: a name for logs, its nominal rate, and its frame count if known."""

    name: str
    fps: float
    frames: int | None
    live: bool


class FrameSource(abc.ABC):
    """Base of all sources: ``info`` plus an iterator of ``(image | None, t_media_ns)``."""

    info: SourceInfo
    #: The ``facesynth`` extra whose packages it imports when built (``facesynth doctor`` checks
    #: that a graph's plugins have theirs); None: no extra.
    needs_extra: ClassVar[str | None] = None
    #: Whether :meth:`frames` may wait long for the next frame (a ROS 2 subscription): the
    #: sensor then takes each frame in a worker thread, so its event loop (and, in
    #: ``facesynth run``, every other stage) keeps running while nothing comes.
    waits: ClassVar[bool] = False

    @abc.abstractmethod
    def frames(self) -> Iterator[tuple[Image, int]]:
        """Yield frames until the source ends."""

    def capture_time_ns(self) -> int | None:
        """The wall-clock capture time (ns) of the frame :meth:`frames` yielded last, when the
        source knows it (a ROS 2 image's stamp); None: the sensor stamps it on taking it."""
        return None

    def capture_clock(self) -> str:
        """Whose clock :meth:`capture_time_ns` read for the frame yielded last, when it is not
        provably this host's (a ROS 2 camera's stamps: ``"ros2:<topic>"``), so the stages
        downstream learn its offset instead of taking it for their own clock; ``""`` (the
        default): this host's clock
        (:func:`~facesynth.runtime.clock_host.clock_host`)."""
        return ""

    def close(self) -> None:  # noqa: B027 - an optional hook: most sources hold nothing
        """Release the device or file (nothing to release by default)."""


@overload
def pixels(image: np.ndarray | JpegImage) -> np.ndarray: ...
@overload
def pixels(image: None) -> None: ...
def pixels(image: Image) -> np.ndarray | None:
    """A source's image as BGR pixels: a camera's JPEG decoded, pixels as they are.

    Raises:
        SourceError: a camera's JPEG that does not decode.
    """
    if not isinstance(image, JpegImage):
        return image
    cv2 = opencv()
    decoded = cv2.imdecode(np.frombuffer(image.data, dtype=np.uint8), cv2.IMREAD_COLOR)
    if decoded is None or decoded.shape[:2] != (image.height, image.width):
        raise SourceError(f"a {image.width}x{image.height} camera JPEG that does not decode")
    return decoded


def opencv() -> ModuleType:
    """The ``cv2`` module; :class:`SourceError` when OpenCV is not installed."""
    return import_cv2(SourceError)
