"""runtime.opencv: one lazy OpenCV import, with the caller's error when OpenCV is missing."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from facesynth.runtime.frames import FrameError, encode_frame
from facesynth.runtime.opencv import import_cv2
from facesynth.services.sensor.sources import SourceError
from facesynth.services.sensor.sources.video import VideoConfig, VideoSource

MISSING = r"^OpenCV is not installed: install facesynth\[tracker\] on hosts that handle images$"


def test_import_cv2_gives_the_module() -> None:
    import cv2

    assert import_cv2(FrameError) is cv2


@pytest.fixture
def no_opencv(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "cv2", None)  # what an install without OpenCV looks like


@pytest.mark.usefixtures("no_opencv")
@pytest.mark.parametrize("error", [FrameError, SourceError])
def test_missing_opencv_raises_the_callers_error(error: type[Exception]) -> None:
    with pytest.raises(error, match=MISSING):
        import_cv2(error)


@pytest.mark.usefixtures("no_opencv")
def test_frames_and_sources_say_opencv_is_missing() -> None:
    with pytest.raises(FrameError, match=MISSING):
        encode_frame(np.zeros((4, 4, 3), np.uint8), seq=0, t_capture_ns=1, t_media_ns=0)
    with pytest.raises(SourceError, match=MISSING):
        VideoSource(VideoConfig(path=__file__))
