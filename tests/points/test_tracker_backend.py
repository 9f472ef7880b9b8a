"""The face tracker as P's backend: Frame in, Points out (``full`` model, the default: ibug68
+ mesh478 + iris10 + the blendshapes52 scores; ``fast``: ibug68 + mesh468 + iris10)."""

from __future__ import annotations

import cv2
import msgspec
import numpy as np
import pytest

from facesynth.app.data import sample_video
from facesynth.runtime import codec
from facesynth.runtime.frames import encode_frame
from facesynth.schemas.messages import Frame
from facesynth.services.points.backends import BackendError
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

SHAPES = {
    "full": {"ibug68": (68, 2), "mesh478": (478, 3), "iris10": (10, 2)},
    "fast": {"ibug68": (68, 2), "mesh468": (468, 3), "iris10": (10, 2)},
}


@pytest.fixture(scope="module")
def video_frames() -> list[np.ndarray]:
    capture = cv2.VideoCapture(str(sample_video()))
    frames = []
    while len(frames) < 12:
        ok, image = capture.read()
        assert ok
        frames.append(image)
    capture.release()
    return frames


def _frame(image: np.ndarray, seq: int, encoding: str = "jpeg") -> Frame:
    return encode_frame(image, seq=seq, t_capture_ns=10 + seq, t_media_ns=seq, encoding=encoding)


@pytest.mark.parametrize("model", ["full", "fast"])
@pytest.mark.parametrize("encoding", ["jpeg", "raw"])
def test_real_frames_give_the_models_point_sets(
    video_frames: list[np.ndarray], encoding: str, model: str
) -> None:
    backend = TrackerBackend(TrackerConfig(model=model))
    for seq, image in enumerate(video_frames):
        points = backend.process(_frame(image, seq, encoding))
        codec.validate_points(points)  # what P publishes passes its own wire checks
        assert points.face and points.confidence > 0.5
        assert (points.seq, points.t_capture_ns) == (seq, 10 + seq)
        assert (points.image_width, points.image_height) == (640, 360)
        shapes = {s.scheme: (len(s.coords) // s.dims, s.dims) for s in points.sets}
        assert shapes == SHAPES[model]
        assert [s.scheme for s in points.scores] == (["blendshapes52"] if model == "full" else [])
        ibug = np.asarray(points.sets[0].coords).reshape(68, 2)
        assert ibug[:, 0].min() >= 0 and ibug[:, 0].max() <= 640
        assert ibug[36, 0] < ibug[45, 0], "right eye outer corner is on the image's left"
        assert ibug[27, 1] < ibug[30, 1] < ibug[8, 1], "nose bridge above nose tip above chin"


def test_blank_frame_after_a_face_gives_no_face_not_stale_points(
    video_frames: list[np.ndarray],
) -> None:
    backend = TrackerBackend()
    assert backend.process(_frame(video_frames[0], 0)).face
    blank = np.zeros_like(video_frames[0])
    points = backend.process(_frame(blank, 1))
    assert not points.face and points.sets == [] and points.scores == []
    assert backend.process(_frame(video_frames[1], 2)).face, "tracking resumes on the next face"


def test_frames_without_pixels_are_refused() -> None:
    tick = Frame(seq=3, t_capture_ns=1, t_media_ns=1, width=640, height=480, encoding="none")
    with pytest.raises(BackendError, match="no pixels"):
        TrackerBackend().process(tick)


def test_corrupt_jpeg_is_a_clear_error(video_frames: list[np.ndarray]) -> None:
    frame = _frame(video_frames[0], 0)
    frame = msgspec.structs.replace(frame, data=frame.data[:300])
    with pytest.raises(ValueError, match="cannot be decoded"):
        TrackerBackend().process(frame)


def test_opencv_gets_the_trackers_thread_count() -> None:
    # OpenCV's own pool would otherwise start a worker per core that spins between frames.
    before = cv2.getNumThreads()
    try:
        TrackerBackend(TrackerConfig(threads=2, model="fast"))
        assert cv2.getNumThreads() == 2
        TrackerBackend(TrackerConfig(model="fast"))
        assert cv2.getNumThreads() == 1
    finally:
        cv2.setNumThreads(before)
