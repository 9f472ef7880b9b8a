"""The ``full`` tracker model: Face Landmarker v2's 478 points, irises and blendshapes."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from tracker_fixtures import VIDEO, TrackedByModel

from facesynth.runtime import blendshapes as names
from facesynth.runtime.frames import encode_frame
from facesynth.services.points.backends.track import TrackFileConfig, TrackReplay
from facesynth.services.points.tracker import FaceTracker
from facesynth.services.points.tracker.blendshapes import LANDMARK_SUBSET, Blendshapes
from facesynth.services.points.tracker.model_files import BLENDSHAPES
from facesynth.services.points.tracker.offline import iter_video_frames, track_video
from facesynth.services.points.tracker.runtimes import load_model

FPS = 23.976
#: The sample video's face sections (seconds), as in tests/integration/test_face_sections.py.
SEGMENTS = {
    "look_down": (0.0, 0.9),
    "frown": (2.0, 3.5),
    "look_up": (7.0, 8.8),
    "smile": (10.6, 11.9),
    "laugh": (13.5, 15.5),
}


def test_the_478_points_hold_the_mesh_and_the_irises(tracked_by_model: TrackedByModel) -> None:
    for r in tracked_by_model["full"].results[::10]:
        assert r.mesh478 is not None and r.mesh is not None and r.iris is not None
        assert r.mesh478.shape == (478, 3)
        np.testing.assert_array_equal(r.mesh, r.mesh478[:468])
        np.testing.assert_array_equal(r.iris[:6], r.mesh478[468:474, :2])
        np.testing.assert_array_equal(r.iris[6:], r.mesh478[[476, 475, 474, 477], :2])
        assert r.blendshapes is not None and r.blendshapes.shape == (52,)
        assert r.blendshapes.min() >= 0.0 and r.blendshapes.max() <= 1.0
        assert r.timings_ms["blendshapes"] > 0 and r.timings_ms["iris"] == 0.0


def test_the_irises_match_the_iris_model_of_the_fast_model(
    tracked_by_model: TrackedByModel,
) -> None:
    """Same order (right eye first, centre then the contour in the iris model's order: each
    contour point lies the same way from its centre) and about the same place (centres within
    a tenth of an eye width at the median; closed eyes make some frames differ more)."""
    fast, full = tracked_by_model["fast"].results, tracked_by_model["full"].results
    same_way, centre_error = [], []
    for a, b in zip(fast, full, strict=True):
        assert a.iris is not None and b.iris is not None and b.mesh is not None
        width = float(np.linalg.norm(b.mesh[33, :2] - b.mesh[133, :2]))
        for eye in (0, 5):
            da = a.iris[eye + 1 : eye + 5] - a.iris[eye]
            db = b.iris[eye + 1 : eye + 5] - b.iris[eye]
            same_way.append((da * db).sum(axis=1) > 0)
            centre_error.append(float(np.linalg.norm(a.iris[eye] - b.iris[eye])) / width)
    assert np.mean(same_way) > 0.98
    assert np.median(centre_error) < 0.1


def test_blendshapes_can_be_switched_off(tracked_by_model: TrackedByModel) -> None:
    tracker = FaceTracker(backend="litert", model="full", iris=False)  # iris: fast only
    r = tracker.process(tracked_by_model["full"].samples[0])
    assert r.face and r.iris is not None and r.blendshapes is not None
    from facesynth.services.points.tracker.landmarkers import model_config

    tracker = FaceTracker(backend="litert", model=model_config("full", blendshapes=False))
    r = tracker.process(tracked_by_model["full"].samples[0])
    assert r.face and r.mesh478 is not None and r.iris is not None
    assert r.blendshapes is None and r.timings_ms["blendshapes"] == 0.0


def test_the_landmark_subset_is_mediapipes() -> None:
    """146 distinct points in increasing order, the last ten the two irises (the table is
    checked against MediaPipe's own output in test_agreement_mediapipe.py)."""
    assert len(LANDMARK_SUBSET) == 146 == BLENDSHAPES.input_size
    assert list(LANDMARK_SUBSET) == sorted(set(LANDMARK_SUBSET))
    assert LANDMARK_SUBSET[-10:] == tuple(range(468, 478))
    assert min(LANDMARK_SUBSET) >= 0 and max(LANDMARK_SUBSET) < 478


def test_the_names_are_the_arkit_52_in_mediapipes_order() -> None:
    assert names.COUNT == 52 and names.NAMES[0] == "_neutral"
    assert list(names.SHAPES) == sorted(names.SHAPES)  # ARKit's names, alphabetical
    assert names.INDEX["jawOpen"] == 25 and names.INDEX["mouthSmileLeft"] == 44


@pytest.mark.parametrize("shape", [(468, 3), (478,), (10, 478, 2), (478, 1)])
def test_the_blendshape_model_wants_478_points(shape: tuple[int, ...]) -> None:
    model = Blendshapes(load_model(BLENDSHAPES, "litert"))
    with pytest.raises(ValueError, match="expected \\(478, 2\\|3\\) points"):
        model.run(np.zeros(shape, np.float32))


# MediaPipe's own Face Landmarker reads these sections the same way (its reference output in
# reference/): the crying "frown" has the lip corners stretched (mouthSmile about 0.65, as in
# the smile), the laugh barely opens the jaw (jawOpen < 0.05), and looking up moves
# eyeLookUp* by only 0.03; so those are not checked here.
def _segment_means(tracked: TrackedByModel) -> dict[str, np.ndarray]:
    results = tracked["full"].results
    means = {}
    for name, (start, end) in SEGMENTS.items():
        chosen = [r.blendshapes for i, r in enumerate(results) if start <= i / FPS < end]
        means[name] = np.mean(np.stack(chosen), axis=0)  # type: ignore[arg-type]
    return means


@pytest.mark.parametrize(
    ("shapes", "higher", "lower", "margin"),
    [
        (("mouthSmileLeft", "mouthSmileRight"), "smile", "look_up", 0.3),
        (("mouthSmileLeft", "mouthSmileRight"), "laugh", "look_up", 0.3),
        (("eyeLookDownLeft", "eyeLookDownRight"), "look_down", "look_up", 0.3),
        (("eyeBlinkLeft", "eyeBlinkRight"), "look_down", "look_up", 0.3),
        (("browInnerUp",), "look_up", "frown", 0.1),
    ],
)
def test_blendshapes_follow_the_performers_face_sections(
    tracked_by_model: TrackedByModel,
    shapes: tuple[str, ...],
    higher: str,
    lower: str,
    margin: float,
) -> None:
    means = _segment_means(tracked_by_model)
    for shape in shapes:
        up, down = means[higher][names.INDEX[shape]], means[lower][names.INDEX[shape]]
        assert up - down >= margin, f"{shape}: {higher} {up:.2f} vs {lower} {down:.2f}"


def test_a_track_file_keeps_the_blendshapes(tmp_path: Path) -> None:
    """``facesynth track --model full`` writes them; the replay puts them back on the bus."""
    out = tmp_path / "full.jsonl"
    video = tmp_path / "short.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 24, (640, 360))
    for frame in iter_video_frames(VIDEO, 6):
        writer.write(frame)
    writer.release()
    summary = track_video(video, out, model="full")
    assert summary["model"] == "full" and summary["faces"] == 6
    replay = TrackReplay(TrackFileConfig(path=str(out)))
    assert replay.gives_blendshapes()
    frame = encode_frame(np.zeros((2, 2, 3), np.uint8), seq=3, t_capture_ns=0, t_media_ns=0)
    points = replay.process(frame)
    assert points.face and points.scores[0].scheme == "blendshapes52"
    assert len(points.scores[0].values) == 52
