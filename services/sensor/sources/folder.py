"""The images of a folder in name order, at a fixed rate."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import msgspec
import numpy as np

from facesynth.services.sensor.sources.base import FrameSource, SourceError, SourceInfo, opencv
from facesynth.services.sensor.sources.registry import SOURCES

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")


class FolderConfig(
    msgspec.Struct, tag="images", tag_field="source", kw_only=True, forbid_unknown_fields=True
):
    """A folder of images, in name order."""

    folder: Annotated[
        str,
        msgspec.Meta(
            description="folder of images, in name order",
            extra={"flag": "--images", "selects": True},
        ),
    ]
    fps: Annotated[float, msgspec.Meta(gt=0, le=1000, description="frame rate override")] | None = (
        None
    )
    loop: Annotated[bool, msgspec.Meta(description="loop the video or image folder")] = False


@SOURCES.register(FolderConfig)
class FolderSource(FrameSource):
    """The images of a folder in name order, at a fixed rate."""

    needs_extra = "tracker"

    def __init__(self, config: FolderConfig) -> None:
        fps = 30.0 if config.fps is None else config.fps
        loop = config.loop
        self.folder = Path(config.folder)
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
        cv2 = opencv()
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
