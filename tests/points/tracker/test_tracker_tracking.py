"""FaceTracker behaviour on the real sample video and on synthetic frames."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest
from tracker_fixtures import VIDEO_FRAMES, TrackedVideo

from facesynth.services.points.tracker import FaceTracker, TrackResult

TIMING_KEYS = {"detect", "mesh", "iris", "blendshapes", "total"}


def _assert_face(r: TrackResult) -> None:
    assert r.face and r.presence >= 0.5
    assert r.mesh is not None and r.mesh.shape == (468, 3) and r.mesh.dtype == np.float32
    assert r.iris is not None and r.iris.shape == (10, 2) and r.iris.dtype == np.float32
    assert r.ibug68 is not None and r.ibug68.shape == (68, 2) and r.ibug68.dtype == np.float32
    assert r.box is not None and len(r.box) == 4 and r.box[2] > 0 and r.box[3] > 0
    assert np.isfinite(r.mesh).all() and np.isfinite(r.iris).all()
    assert set(r.timings_ms) == TIMING_KEYS
    assert r.timings_ms["total"] >= r.timings_ms["mesh"] + r.timings_ms["iris"] > 0


def _assert_no_face(r: TrackResult) -> None:
    assert not r.face
    assert r.mesh is None and r.iris is None and r.ibug68 is None and r.box is None
    assert set(r.timings_ms) == TIMING_KEYS


def test_face_on_every_frame_of_the_sample_video(tracked_video: TrackedVideo) -> None:
    """The performer covers her face with a hand at times; the mesh keeps it on all 472."""
    results = tracked_video.results
    assert len(results) == VIDEO_FRAMES
    lost = [i for i, r in enumerate(results) if not r.face]
    assert lost == []
    for r in results:
        _assert_face(r)
    assert min(r.presence for r in results) > 0.9


def test_detector_runs_first_then_every_30_frames(tracked_video: TrackedVideo) -> None:
    detected = [i for i, r in enumerate(tracked_video.results) if r.detected]
    assert detected == list(range(0, VIDEO_FRAMES, 30))
    for i, r in enumerate(tracked_video.results):
        assert (r.timings_ms["detect"] > 0) == (i in detected)


def test_points_lie_on_the_face(tracked_video: TrackedVideo) -> None:
    for r in tracked_video.results:
        assert r.mesh is not None and r.iris is not None and r.box is not None
        x, y, w, h = r.box
        assert 250 < x + w / 2 < 560 and 80 < y + h / 2 < 330  # where she is in the frame
        assert 150 < w < 300
        # z is in frame pixels too: the face is ~0.7-0.85 of its width deep, nose nearest
        z_span = float(r.mesh[:, 2].max() - r.mesh[:, 2].min())
        assert 0.55 * w < z_span < 1.0 * w
        assert r.mesh[1, 2] < min(r.mesh[234, 2], r.mesh[454, 2])
        # iris centres sit between their eye's corners
        for centre, (a, b) in ((r.iris[0], (33, 133)), (r.iris[5], (362, 263))):
            lo, hi = sorted((r.mesh[a, 0], r.mesh[b, 0]))
            assert lo < centre[0] < hi


def test_still_image_is_stable(tracker: FaceTracker, tracked_video: TrackedVideo) -> None:
    for frame in list(tracked_video.samples.values())[::3]:
        tracker.reset()
        rs = [tracker.process(frame) for _ in range(20)]
        assert [r.detected for r in rs] == [True] + [False] * 19
        meshes = np.stack([r.mesh for r in rs if r.mesh is not None])
        iris = np.stack([r.iris for r in rs if r.iris is not None])
        assert len(meshes) == len(iris) == 20
        # after the first tracked frame the crop settles and the points stop moving
        assert meshes[2:, :, :2].std(axis=0).max() < 0.05
        assert iris[2:].std(axis=0).max() < 0.05
        # including the detection-cropped first frame, jitter stays around a pixel
        assert meshes[:, :, :2].std(axis=0).mean() < 1.0


def _synthetic(kind: str) -> np.ndarray:
    if kind == "blank":
        return np.zeros((360, 640, 3), np.uint8)
    if kind == "white":
        return np.full((360, 640, 3), 255, np.uint8)
    if kind == "gradient":
        return np.tile(np.linspace(0, 255, 640).astype(np.uint8)[None, :, None], (360, 1, 3))
    if kind == "noise":
        return np.random.default_rng(1).integers(0, 256, (360, 640, 3), dtype=np.uint8)
    raise AssertionError(kind)


@pytest.mark.parametrize("kind", ["blank", "white", "gradient", "noise", "background"])
def test_no_face_frames(tracker: FaceTracker, tracked_video: TrackedVideo, kind: str) -> None:
    if kind == "background":  # the wall left of the performer
        img = np.ascontiguousarray(tracked_video.samples[0][:, :250])
    else:
        img = _synthetic(kind)
    r = tracker.process(img)
    _assert_no_face(r)
    assert r.detected and r.presence == 0.0
    # ... also straight after a tracked face: no stale points
    face_frame = tracked_video.samples[0]
    _assert_face(tracker.process(face_frame))
    r = tracker.process(img)
    _assert_no_face(r)
    assert r.detected and r.presence < 0.5
    assert not tracker.tracking
    _assert_face(tracker.process(face_frame))


def test_reset_forces_detection(tracker: FaceTracker, tracked_video: TrackedVideo) -> None:
    frame = tracked_video.samples[40]
    assert tracker.process(frame).detected
    assert not tracker.process(frame).detected
    tracker.reset()
    assert not tracker.tracking
    assert tracker.process(frame).detected


def test_result_is_frozen(tracker: FaceTracker, tracked_video: TrackedVideo) -> None:
    r = tracker.process(tracked_video.samples[0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.face = False  # type: ignore[misc]


@pytest.mark.parametrize(
    "image",
    [
        np.zeros((360, 640, 3), np.float32),
        np.zeros((360, 640, 2), np.uint8),
        np.zeros((0, 640, 3), np.uint8),
        "not an image",
    ],
    ids=["float", "2-channel", "empty", "str"],
)
def test_invalid_input_is_a_value_error(tracker: FaceTracker, image: object) -> None:
    with pytest.raises(ValueError):
        tracker.process(image)  # type: ignore[arg-type]


def test_grey_and_bgra_frames_are_accepted(
    tracker: FaceTracker, tracked_video: TrackedVideo
) -> None:
    frame = tracked_video.samples[0]
    bgr = tracker.process(frame)
    for img in (cv2.cvtColor(frame, cv2.COLOR_BGR2BGRA), cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)):
        tracker.reset()
        r = tracker.process(img)
        _assert_face(r)
        assert r.mesh is not None and bgr.mesh is not None
        assert np.abs(r.mesh[:, :2] - bgr.mesh[:, :2]).mean() < (0.01 if img.ndim == 3 else 3.0)


@pytest.mark.parametrize(
    "kwargs",
    [{"select": "biggest"}, {"redetect_every": 0}, {"min_presence": 1.5}, {"backend": "tf"}],
)
def test_bad_arguments(kwargs: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        FaceTracker(**kwargs)  # type: ignore[arg-type]


def _paste(
    canvas: np.ndarray, frame: np.ndarray, box: tuple[int, ...], scale: float, cx: int
) -> None:
    x0, y0, x1, y1 = box
    patch = cv2.resize(frame[y0:y1, x0:x1], None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    h, w = patch.shape[:2]
    top, left = max(0, 180 - h // 2), max(0, cx - w // 2)
    h, w = min(h, 360 - top), min(w, 640 - left)
    canvas[top : top + h, left : left + w] = patch[:h, :w]


def _two_faces(tv: TrackedVideo, right_scale: float, left_scale: float) -> np.ndarray:
    """Performer at frame 0 on the right, the same performer at frame 240 on the left."""
    img = np.full((360, 640, 3), 40, np.uint8)
    _paste(img, tv.samples[0], (330, 60, 580, 350), right_scale, 480)
    _paste(img, tv.samples[240], (330, 40, 590, 330), left_scale, 160)
    return img


def _centre_x(r: TrackResult) -> float:
    assert r.box is not None
    return r.box[0] + r.box[2] / 2


@pytest.mark.parametrize("select", ["largest", "score"])
def test_several_faces_follow_one_performer(tracked_video: TrackedVideo, select: str) -> None:
    big_right = _two_faces(tracked_video, 1.0, 0.6)
    big_left = _two_faces(tracked_video, 0.75, 1.0)
    tracker = FaceTracker(backend="litert", redetect_every=1, select=select)
    assert len(tracker.detector.detect(big_right)) == 2
    assert len(tracker.detector.detect(big_left)) == 2
    if select == "largest":
        first = tracker.process(big_right)
        assert first.face and _centre_x(first) > 320  # the largest face, on the right
    else:
        first = tracker.process(big_right)
        assert first.face
    side = _centre_x(first) > 320
    # the other face is now the larger one, and the detector runs on every frame: stay put
    for _ in range(4):
        r = tracker.process(big_left)
        assert r.face and r.detected
        assert (_centre_x(r) > 320) == side
    # a fresh start picks the largest face, on the left (for "largest")
    tracker.reset()
    r = tracker.process(big_left)
    assert r.face
    if select == "largest":
        assert _centre_x(r) < 320


def test_iris_can_be_switched_off(tracked_video: TrackedVideo) -> None:
    tracker = FaceTracker(backend="litert", iris=False)
    r = tracker.process(tracked_video.samples[0])
    assert r.face and r.mesh is not None and r.ibug68 is not None
    assert r.iris is None and r.timings_ms["iris"] == 0.0


def test_lost_track_is_found_again_on_the_same_frame(tracked_video: TrackedVideo) -> None:
    """The face jumps across the frame: the tracked crop is empty, so the tracker re-detects
    on that very frame instead of reporting a gap."""
    right = np.full((360, 640, 3), 40, np.uint8)
    left = right.copy()
    _paste(right, tracked_video.samples[0], (330, 60, 580, 350), 1.0, 480)
    _paste(left, tracked_video.samples[0], (330, 60, 580, 350), 1.0, 160)
    tracker = FaceTracker(backend="litert", redetect_every=None)
    assert _centre_x(tracker.process(right)) > 320
    r = tracker.process(right)
    assert r.face and not r.detected
    r = tracker.process(left)
    assert r.face and r.detected and r.timings_ms["detect"] > 0
    assert r.timings_ms["mesh"] > 0 and _centre_x(r) < 320
    r = tracker.process(left)
    assert r.face and not r.detected and _centre_x(r) < 320


def test_eye_crops_are_oriented_as_the_iris_model_expects(
    litert_tracker: FaceTracker, tracked_video: TrackedVideo
) -> None:
    """The iris model's own 16-point eye contour matches the mesh's eye vertices point by
    point (~0.02-0.03 inter-ocular); with the wrong eye mirrored it is off by ~0.16."""
    from facesynth.services.points.tracker.iris import EYE_CONTOUR_VERTICES
    from facesynth.services.points.tracker.model_input import frame_to_rgba

    iris = getattr(litert_tracker.model, "iris", None)
    assert iris is not None
    for i, frame in tracked_video.samples.items():
        mesh = tracked_video.results[i].mesh
        assert mesh is not None
        iris.run(frame_to_rgba(frame), mesh)
        contours = iris.last_contours
        assert contours is not None
        iod = float(np.linalg.norm(mesh[33, :2] - mesh[263, :2]))
        for eye in (0, 1):
            ref = mesh[list(EYE_CONTOUR_VERTICES[eye]), :2]
            err = np.linalg.norm(contours[eye, :16] - ref, axis=1).mean() / iod
            assert err < 0.06, (i, eye, err)
