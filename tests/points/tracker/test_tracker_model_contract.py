"""The contract every registered tracker model meets (run against each of them).

A new model module that registers itself is picked up here through the registry: it must find
the performer on every frame of the sample video, report no face on blank and noise frames,
keep its points inside the image and around the face, derive the 68 points from its mesh, put
the irises in the eyes, hold still on a still image, agree across inference backends, refuse
damaged model files with a clear :class:`ModelError`, and publish valid messages.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import msgspec
import numpy as np
import pytest
from tracker_fixtures import VIDEO, VIDEO_FRAMES, TrackedByModel

from facesynth.runtime import codec
from facesynth.runtime.frames import encode_frame
from facesynth.runtime.plugins import PluginError
from facesynth.schemas.messages import Points
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig
from facesynth.services.points.tracker import FaceTracker, ModelError, mesh_to_ibug68
from facesynth.services.points.tracker.landmarkers import TRACKER_MODELS, model_config, model_names
from facesynth.services.points.tracker.model_files import DETECTOR, MODELS_DIR, ModelSpec
from facesynth.services.points.tracker.offline import iter_video_frames
from facesynth.services.points.tracker.runtimes import load_model

MODELS = model_names()


def test_the_shipped_models_are_registered() -> None:
    assert {"fast", "full"} <= set(MODELS)
    for plugin in TRACKER_MODELS:
        assert plugin.summary and plugin.config.__struct_config__.tag == plugin.name
        # every option has a default: the bare name is a complete configuration
        assert type(model_config(plugin.name)) is plugin.config


def _files(model: str) -> list[ModelSpec]:
    """The model files a tracker model loads (recorded through its loader)."""
    specs: list[ModelSpec] = []

    def load(spec: ModelSpec, batch: int):  # type: ignore[no-untyped-def]
        specs.append(spec)
        return load_model(spec, "litert", batch=batch)

    TRACKER_MODELS.build(model_config(model), load)
    return specs


@pytest.mark.parametrize("model", MODELS)
def test_faces_found_on_every_frame_of_the_sample_video(
    tracked_by_model: TrackedByModel, model: str
) -> None:
    results = tracked_by_model[model].results
    assert len(results) == VIDEO_FRAMES
    assert all(r.face and r.presence >= 0.5 for r in results)
    # tracking: the detector runs on the first frame and then only every 30 frames
    assert sum(r.detected for r in results) <= VIDEO_FRAMES // 30 + 2


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("kind", ["black", "grey", "noise"])
def test_no_face_on_a_blank_frame(model: str, kind: str) -> None:
    rng = np.random.default_rng(7)
    frames = {
        "black": np.zeros((360, 640, 3), np.uint8),
        "grey": np.full((360, 640, 3), 128, np.uint8),
        "noise": rng.integers(0, 256, (360, 640, 3), dtype=np.uint8),
    }
    tracker = FaceTracker(backend="litert", model=model)
    for _ in range(3):
        r = tracker.process(frames[kind])
        assert not r.face and r.detected
        assert r.mesh is None and r.iris is None and r.ibug68 is None
        assert r.mesh478 is None and r.blendshapes is None


def _inside(points: np.ndarray, margin: float) -> bool:
    x, y = points[:, 0], points[:, 1]
    return bool(
        x.min() >= -margin
        and x.max() < 640 + margin
        and y.min() >= -margin
        and y.max() < 360 + margin
    )


@pytest.mark.parametrize("model", MODELS)
def test_points_lie_within_the_image_and_around_the_face(
    tracked_by_model: TrackedByModel, model: str
) -> None:
    """The eyes and irises lie inside the image; the face outline may run a little past its
    edge where the face does (the performer's chin leaves the frame at times: up to 13 px)."""
    for r in tracked_by_model[model].results:
        assert r.mesh is not None and r.ibug68 is not None and r.box is not None
        assert r.iris is not None
        assert r.mesh.shape == (468, 3) and r.mesh.dtype == np.float32
        assert np.all(np.isfinite(r.mesh))
        assert _inside(r.iris, 0.0) and _inside(r.ibug68[36:48], 0.0)
        assert _inside(r.mesh, 0.05 * 360) and _inside(r.ibug68, 0.05 * 360)
        _, _, w, h = r.box
        assert 60 < w < 400 and 60 < h < 400  # the performer's face, not the whole frame


@pytest.mark.parametrize("model", MODELS)
def test_the_68_points_are_derived_from_the_mesh(
    tracked_by_model: TrackedByModel, model: str
) -> None:
    for r in tracked_by_model[model].results[::25]:
        assert r.mesh is not None and r.ibug68 is not None
        np.testing.assert_allclose(r.ibug68, mesh_to_ibug68(r.mesh), atol=1e-4)


@pytest.mark.parametrize("model", MODELS)
def test_each_iris_lies_between_its_eye_corners(
    tracked_by_model: TrackedByModel, model: str
) -> None:
    for r in tracked_by_model[model].results[::5]:
        assert r.mesh is not None and r.iris is not None
        for centre, (a, b) in ((r.iris[0], (33, 133)), (r.iris[5], (362, 263))):
            corner_a, corner_b = r.mesh[a, :2], r.mesh[b, :2]
            width = float(np.linalg.norm(corner_b - corner_a))
            along = float(np.dot(centre - corner_a, corner_b - corner_a)) / width**2
            middle = (corner_a + corner_b) / 2
            assert 0.05 < along < 0.95, along
            assert np.linalg.norm(centre - middle) < 0.4 * width


@pytest.mark.parametrize("model", MODELS)
def test_a_still_image_gives_the_same_points_every_frame(
    tracked_by_model: TrackedByModel, model: str
) -> None:
    frame = tracked_by_model[model].samples[200]
    tracker = FaceTracker(backend="litert", model=model, redetect_every=None)
    results = [tracker.process(frame) for _ in range(6)]
    meshes = [r.mesh for r in results[2:]]
    assert all(m is not None for m in meshes)
    for mesh in meshes[1:]:
        np.testing.assert_array_equal(mesh, meshes[0])


@pytest.mark.parametrize("model", MODELS)
def test_both_inference_backends_agree(tracked_by_model: TrackedByModel, model: str) -> None:
    """The OpenCV tracker follows the LiteRT one over the video's start (< 0.5 px mean)."""
    tracker = FaceTracker(backend="opencv", model=model)
    reference = tracked_by_model[model].results
    errors = []
    for i, frame in enumerate(iter_video_frames(VIDEO, max_frames=30)):
        r = tracker.process(frame)
        ref = reference[i]
        assert r.face and r.mesh is not None and ref.mesh is not None
        errors.append(float(np.linalg.norm(r.mesh[:, :2] - ref.mesh[:, :2], axis=1).mean()))
        if ref.blendshapes is not None:
            assert r.blendshapes is not None
            assert np.abs(r.blendshapes - ref.blendshapes).max() < 0.02
    assert np.mean(errors) < 0.5 and max(errors) < 2.0, errors


def _truncate(p: Path) -> None:
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])


def _garbage(p: Path) -> None:
    p.write_bytes(b"this is not a flatbuffer " * 200)


def _missing(p: Path) -> None:
    p.unlink()


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize(
    ("damage", "message"), [(_truncate, "corrupt"), (_garbage, "corrupt"), (_missing, "not found")]
)
def test_a_damaged_model_file_is_a_clear_model_error(
    tmp_path: Path, model: str, damage: object, message: str
) -> None:
    files = [DETECTOR, *_files(model)]
    for spec in files:
        shutil.copy(MODELS_DIR / spec.filename, tmp_path / spec.filename)
    FaceTracker(backend="litert", model=model, model_dir=tmp_path)  # intact: loads
    for spec in files:
        folder = tmp_path / spec.filename.removesuffix(".tflite")
        folder.mkdir()
        for other in files:
            shutil.copy(MODELS_DIR / other.filename, folder / other.filename)
        damage(folder / spec.filename)  # type: ignore[operator]
        with pytest.raises(ModelError, match=message) as info:
            FaceTracker(backend="litert", model=model, model_dir=folder)
        assert spec.filename in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("model", MODELS)
def test_the_backend_publishes_valid_points(tracked_by_model: TrackedByModel, model: str) -> None:
    frame_bgr = tracked_by_model[model].samples[80]
    backend = TrackerBackend(TrackerConfig(inference="litert", model=model))
    frame = encode_frame(frame_bgr, seq=4, t_capture_ns=1, t_media_ns=2, encoding="raw")
    points = codec.decode(codec.encode(backend.process(frame)), Points)
    assert points.face and points.seq == 4
    schemes = [s.scheme for s in points.sets]
    assert schemes[0] == "ibug68" and "iris10" in schemes
    assert ("mesh478" in schemes) != ("mesh468" in schemes)
    assert backend.gives_blendshapes() == bool(points.scores)
    blank = msgspec.structs.replace(frame, data=bytes(640 * 360 * 3))
    gone = backend.process(blank)
    assert not gone.face and not gone.sets and not gone.scores


def test_model_options_are_checked() -> None:
    with pytest.raises(PluginError, match="unknown tracker model 'huge' \\(known: fast, full"):
        model_config("huge")
    with pytest.raises(PluginError, match=r"tracker model full: .*unknown field `iris`"):
        model_config("full", iris=False)
    with pytest.raises(PluginError, match="unknown tracker model"):
        FaceTracker(model="huge")
    with pytest.raises(msgspec.ValidationError, match="unknown tracker model 'huge'"):
        msgspec.convert({"model": "huge"}, TrackerConfig)
    full = model_config("full", blendshapes=False)
    assert model_config(full) is full
    assert TrackerConfig(model="full", blendshapes=False).model_config() == full
    assert TrackerConfig(model="fast", blendshapes=False).model_config() == model_config("fast")
