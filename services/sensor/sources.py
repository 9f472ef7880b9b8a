"""Where frames come from: a video file, a camera, a folder of images, or plain timing ticks.

Every source yields ``(image or None, t_media_ns)``; ``None`` images are ticks (no pixels).
"""

from __future__ import annotations

import abc
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from facesynth.runtime.opencv import import_cv2

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")


class SourceError(ValueError):
    """A source that cannot be opened or read (missing file, not a video, no camera)."""


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

    @abc.abstractmethod
    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        """Yield frames until the source ends."""

    def close(self) -> None:  # noqa: B027 - an optional hook: most sources hold nothing
        """Release the device or file (nothing to release by default)."""


class VideoSource(FrameSource):
    """Frames of a video file, timed by their index and the file's frame rate."""

    def __init__(self, path: str | Path, *, loop: bool = False, fps: float | None = None) -> None:
        cv2 = import_cv2(SourceError)
        self.path = Path(path)
        if not self.path.is_file():
            raise SourceError(f"video {self.path} does not exist")
        self.loop = loop
        self._capture = cv2.VideoCapture(str(self.path))
        if not self._capture.isOpened():
            raise SourceError(f"cannot open {self.path} as a video")
        rate = fps or float(self._capture.get(cv2.CAP_PROP_FPS) or 0.0)
        if not rate > 0 or rate > 1000:
            rate = 30.0
        count = int(self._capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
        self.info = SourceInfo(str(self.path), rate, count or None, live=False)

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        cv2 = import_cv2(SourceError)
        period_ns = 1e9 / self.info.fps
        index = 0
        while True:
            ok, image = self._capture.read()
            if not ok:
                if index == 0:
                    raise SourceError(f"{self.path}: no frame could be decoded")
                if not self.loop:
                    return
                self._capture.set(cv2.CAP_PROP_POS_FRAMES, 0)
                ok, image = self._capture.read()
                if not ok:
                    return
            yield image, round(index * period_ns)
            index += 1

    def close(self) -> None:
        self._capture.release()


class CameraSource(FrameSource):
    """A live camera with a one-frame buffer, timed by the wall clock."""

    def __init__(self, index: int, *, width: int = 0, height: int = 0, fps: float = 0.0) -> None:
        cv2 = import_cv2(SourceError)
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


class FolderSource(FrameSource):
    """The images of a folder in name order, at a fixed rate."""

    def __init__(self, folder: str | Path, *, fps: float = 30.0, loop: bool = False) -> None:
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise SourceError(f"image folder {self.folder} does not exist")
        self.files = sorted(p for p in self.folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not self.files:
            raise SourceError(f"no images ({', '.join(IMAGE_SUFFIXES)}) in {self.folder}")
        if not fps > 0:
            raise SourceError("the image folder rate must be positive")
        self.loop = loop
        self.info = SourceInfo(str(self.folder), fps, len(self.files), live=False)

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        cv2 = import_cv2(SourceError)
        period_ns = 1e9 / self.info.fps
        index = 0
        while True:
            for path in self.files:
                image = cv2.imread(str(path), cv2.IMREAD_COLOR)
                if image is None:
                    raise SourceError(f"{path} is not a readable image")
                yield image, round(index * period_ns)
                index += 1
            if not self.loop:
                return


class TickSource(FrameSource):
    """Frames without pixels at a fixed rate: the clock for replayed point streams."""

    def __init__(self, count: int, *, fps: float = 30.0) -> None:
        if count < 1 or not fps > 0:
            raise SourceError("ticks need a positive count and rate")
        self.count = count
        self.info = SourceInfo("ticks", fps, count, live=False)

    def frames(self) -> Iterator[tuple[np.ndarray | None, int]]:
        period_ns = 1e9 / self.info.fps
        for index in range(self.count):
            yield None, round(index * period_ns)
