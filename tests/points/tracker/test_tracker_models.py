"""Model files (checksums, provenance, clear errors) and the two inference backends."""

from __future__ import annotations

import hashlib
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from tracker_fixtures import VIDEO, TrackedVideo

from facesynth.services.points.tracker import FaceTracker, ModelError
from facesynth.services.points.tracker.mesh import rect_from_mesh
from facesynth.services.points.tracker.model_files import (
    DETECTOR,
    IRIS,
    MESH,
    MODELS_DIR,
    ModelSpec,
    read_model_bytes,
)
from facesynth.services.points.tracker.model_input import frame_to_rgba
from facesynth.services.points.tracker.offline import iter_video_frames
from facesynth.services.points.tracker.runtimes import (
    available_backends,
    load_model,
    resolve_backend,
)

SPECS = [DETECTOR, MESH, IRIS]


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: s.filename)
def test_bundled_files_match_checksums_and_provenance(spec: ModelSpec) -> None:
    data = (MODELS_DIR / spec.filename).read_bytes()
    assert hashlib.sha256(data).hexdigest() == spec.sha256
    provenance = (MODELS_DIR / "PROVENANCE.md").read_text(encoding="utf-8")
    row = re.search(rf"`{re.escape(spec.filename)}` \| (\d+) \| `([0-9a-f]{{64}})`", provenance)
    assert row is not None
    assert int(row.group(1)) == len(data) and row.group(2) == spec.sha256


def test_license_is_apache() -> None:
    text = (MODELS_DIR / "LICENSE").read_text(encoding="utf-8")
    assert "Apache License" in text and "Version 2.0" in text


def test_backends_available_and_resolved() -> None:
    assert available_backends() == ("litert", "opencv")
    assert resolve_backend("auto") == "litert"
    assert resolve_backend("opencv") == "opencv"
    with pytest.raises(ValueError, match="unknown backend"):
        resolve_backend("tensorflow")


def _copy_models(dst: Path) -> None:
    for spec in SPECS:
        shutil.copy(MODELS_DIR / spec.filename, dst / spec.filename)


def _truncate(p: Path) -> None:
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])


def _garbage(p: Path) -> None:
    p.write_bytes(b"this is not a flatbuffer " * 200)


def _missing(p: Path) -> None:
    p.unlink()


def _directory(p: Path) -> None:
    p.unlink()
    p.mkdir()


def _empty(p: Path) -> None:
    p.write_bytes(b"")


@pytest.mark.parametrize(
    "damage, message",
    [
        (_truncate, "corrupt"),
        (_garbage, "corrupt"),
        (_missing, "not found"),
        (_directory, "unreadable"),
        (_empty, "empty"),
    ],
)
@pytest.mark.parametrize("spec", SPECS, ids=lambda s: s.filename)
def test_damaged_model_file_gives_model_error(
    tmp_path: Path, spec: ModelSpec, damage: object, message: str
) -> None:
    _copy_models(tmp_path)
    damage(tmp_path / spec.filename)  # type: ignore[operator]
    with pytest.raises(ModelError, match=message) as info:
        FaceTracker(backend="litert", model_dir=tmp_path)
    assert isinstance(info.value, ValueError)
    assert spec.filename in str(info.value)


@pytest.mark.parametrize("backend", ["litert", "opencv"])
@pytest.mark.parametrize("damage", [_truncate, _garbage])
def test_unverified_garbage_is_still_a_model_error(
    tmp_path: Path, backend: str, damage: object
) -> None:
    """Without the checksum the runtime's own parse failure is wrapped, not leaked."""
    _copy_models(tmp_path)
    damage(tmp_path / MESH.filename)  # type: ignore[operator]
    with pytest.raises(ModelError, match="cannot load model"):
        load_model(MESH, backend, model_dir=tmp_path, verify=False)


def test_wrong_model_for_the_slot_is_a_model_error(tmp_path: Path) -> None:
    """A valid .tflite of another model fails the output-name check when not verified."""
    shutil.copy(MODELS_DIR / IRIS.filename, tmp_path / MESH.filename)
    for backend in ("litert", "opencv"):
        with pytest.raises(ModelError):
            load_model(MESH, backend, model_dir=tmp_path, verify=False)


def test_read_model_bytes_checks_sha(tmp_path: Path) -> None:
    p = tmp_path / "m.tflite"
    p.write_bytes(b"abc")
    assert read_model_bytes(p, hashlib.sha256(b"abc").hexdigest()) == b"abc"
    assert read_model_bytes(p, None) == b"abc"
    with pytest.raises(ModelError, match="sha256"):
        read_model_bytes(p, "0" * 64)


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: s.filename)
def test_backends_give_the_same_raw_outputs(spec: ModelSpec) -> None:
    rng = np.random.default_rng(3)
    models = [load_model(spec, b, batch=2) for b in ("litert", "opencv")]
    x = rng.uniform(-1, 1, models[0].input_view().shape).astype(np.float32)
    outs = []
    for m in models:
        m.input_view()[...] = x
        outs.append(m.run())
    for name in spec.outputs:
        a, b = outs[0][name], outs[1][name]
        assert a.shape == b.shape and a.shape[0] == 2
        np.testing.assert_allclose(a, b, rtol=1e-3, atol=1e-3 * max(1.0, np.abs(a).max()))


def test_backends_agree_on_real_frames(
    tracked_video: TrackedVideo, litert_tracker: FaceTracker, opencv_tracker: FaceTracker
) -> None:
    """Same crop, both backends: mesh and iris agree to well under half a pixel."""
    mesh_err, iris_err = [], []
    for i, frame in tracked_video.samples.items():
        prev = tracked_video.results[max(i - 1, 0)].mesh
        assert prev is not None
        rect = rect_from_mesh(prev)
        rgba = frame_to_rgba(frame)
        m1, p1 = litert_tracker.model.mesh(rgba, rect)
        m2, p2 = opencv_tracker.model.mesh(rgba, rect)
        assert abs(p1 - p2) < 0.01
        mesh_err.append(np.linalg.norm(m1[:, :2] - m2[:, :2], axis=1).mean())
        i1 = litert_tracker.model.extras(rgba, m1, {}).iris
        i2 = opencv_tracker.model.extras(rgba, m1, {}).iris
        assert i1 is not None and i2 is not None
        iris_err.append(np.linalg.norm(i1 - i2, axis=1).mean())
    assert max(mesh_err) < 0.05, mesh_err
    assert max(iris_err) < 0.05, iris_err


def test_whole_trackers_agree_on_the_video_start(
    tracked_video: TrackedVideo, opencv_tracker: FaceTracker
) -> None:
    """The OpenCV tracker run from scratch follows the LiteRT one (< 0.5 px mean)."""
    opencv_tracker.reset()
    errs = []
    for i, frame in enumerate(iter_video_frames(VIDEO, max_frames=40)):
        r = opencv_tracker.process(frame)
        ref = tracked_video.results[i]
        assert r.face and ref.face
        assert r.detected == ref.detected
        assert r.mesh is not None and ref.mesh is not None
        errs.append(np.linalg.norm(r.mesh[:, :2] - ref.mesh[:, :2], axis=1).mean())
    assert np.mean(errs) < 0.5 and max(errs) < 2.0, errs
