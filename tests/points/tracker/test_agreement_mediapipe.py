"""The ``full`` model agrees with MediaPipe's own Face Landmarker on the sample video.

``reference/mediapipe_face_landmarker.npz`` is MediaPipe 0.10.21's Face Landmarker task (VIDEO
mode, blendshapes on, ``face_landmarker.task``) run once on the bundled video, every second
frame, by ``tools/mediapipe/reference.py`` (see its docstring; mediapipe is not a facesynth
dependency, so CI only reads the file). facesynth's ``full`` model, tracking the same video
with its own detector, crops and runtime, must agree:

* landmarks: the median distance over frames and all 478 points within 1 % of the
  inter-ocular distance (outer eye corners, 33-263; measured: about 0.8 %);
* blendshapes: per shape, the median absolute difference over frames within 0.05.

For scale: MediaPipe's own VIDEO and IMAGE modes differ by 1.3 % of the inter-ocular distance
at the median on this video, and by up to 0.13 on a blendshape.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from tracker_fixtures import VIDEO, VIDEO_FRAMES, TrackedByModel

from facesynth.runtime import blendshapes

REFERENCE = Path(__file__).with_name("reference") / "mediapipe_face_landmarker.npz"
LANDMARK_TOLERANCE_IOD = 0.01
BLENDSHAPE_TOLERANCE = 0.05


@pytest.fixture(scope="module")
def reference() -> dict[str, np.ndarray]:
    with np.load(REFERENCE) as data:
        return {key: data[key] for key in data.files}


@pytest.fixture(scope="module")
def meta(reference: dict[str, np.ndarray]) -> dict[str, object]:
    result: dict[str, object] = json.loads(str(reference["meta"]))
    return result


def test_the_reference_is_mediapipes_run_on_the_bundled_video(
    reference: dict[str, np.ndarray], meta: dict[str, object]
) -> None:
    assert REFERENCE.stat().st_size < 1_000_000
    assert meta["mediapipe"] == "0.10.21" and meta["mode"] == "video"
    assert meta["video_sha256"] == hashlib.sha256(VIDEO.read_bytes()).hexdigest()
    assert meta["frames_read"] == VIDEO_FRAMES and meta["size"] == [640, 360]
    assert reference["face"].all() and len(reference["frames"]) == VIDEO_FRAMES // 2
    assert list(reference["names"]) == list(blendshapes.NAMES)


def _ours(tracked: TrackedByModel, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    results = tracked["full"].results
    points, scores = [], []
    for index in frames:
        r = results[int(index)]
        assert r.mesh478 is not None and r.blendshapes is not None
        points.append(r.mesh478[:, :2])
        scores.append(r.blendshapes)
    return np.stack(points), np.stack(scores)


def test_landmarks_agree_with_mediapipe(
    tracked_by_model: TrackedByModel, reference: dict[str, np.ndarray], meta: dict[str, object]
) -> None:
    ours, _ = _ours(tracked_by_model, reference["frames"])
    theirs = reference["xy"].astype(np.float64) / float(meta["xy_scale"])  # type: ignore[arg-type]
    iod = np.linalg.norm(theirs[:, 33] - theirs[:, 263], axis=1)
    error = np.linalg.norm(ours - theirs, axis=2) / iod[:, None]
    assert np.median(error) < LANDMARK_TOLERANCE_IOD, np.median(error)
    # and no frame is off altogether (a wrong face, a lost track)
    assert np.median(error, axis=1).max() < 0.05


def test_blendshapes_agree_with_mediapipe(
    tracked_by_model: TrackedByModel, reference: dict[str, np.ndarray]
) -> None:
    _, ours = _ours(tracked_by_model, reference["frames"])
    theirs = reference["blendshapes"].astype(np.float64)
    median = np.median(np.abs(ours - theirs), axis=0)
    worst = int(np.argmax(median))
    assert median.max() < BLENDSHAPE_TOLERANCE, (blendshapes.NAMES[worst], median[worst])
