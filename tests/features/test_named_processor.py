"""FeatureProcessor's named features, displacements, calibrations and the blink/wink rule."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_face import IRIS, MESH, S, ibug_of, look, move, points_message, transform

from facesynth.runtime import codec
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.feature_names import BY_NAME, LANDMARK_NAMES, NAMES
from facesynth.schemas.messages import Features, PointSet
from facesynth.services.features.core import (
    FeatureError,
    FeatureProcessor,
    Sample,
    neutral_face,
    normalise,
    nose_distances,
)
from facesynth.services.features.expressions import BROW, LID_UPPER, MESH_ONLY, raw_features
from facesynth.services.features.pose import STABLE_VERTICES
from facesynth.services.points.tracker.iris import EYE_CONTOUR_VERTICES

FPS = 30
GAZE = [n for n in NAMES if n.startswith("gaze_")]
RIGHT_BROW_RAISED = move(MESH, BROW["right"].mesh, dy=0.05)


def _feed(processor: FeatureProcessor, frames, start: int = 0) -> list[Features]:
    """Process (mesh, iris) pairs at FPS from frame number ``start``."""
    out = []
    for i, (mesh, iris) in enumerate(frames, start):
        message = points_message(mesh, iris, seq=i, t_media_ns=i * S // FPS)
        features = processor.process(message)
        codec.validate_features(features)  # what F publishes passes its own wire checks
        out.append(features)
    return out


def _neutral_second(processor: FeatureProcessor) -> list[Features]:
    return _feed(processor, [(MESH, IRIS)] * (FPS + 1))


@pytest.mark.parametrize("auto_range", [False, True], ids=["fixed", "auto"])
def test_still_face_holds_still(auto_range: bool) -> None:
    processor = FeatureProcessor(auto_range=auto_range)
    outs = _feed(processor, [(MESH, IRIS)] * (FPS * 20))  # 20 s of one image
    assert [o.neutral_ready for o in outs[: FPS + 1]] == [False] * FPS + [True]
    assert all(o.named == {} and o.raw == {} and o.displacements == [] for o in outs[:FPS])
    for out in outs[FPS:]:
        assert set(out.named) == set(LANDMARK_NAMES)
        assert max(abs(v) for v in out.named.values()) <= 1e-6
        assert max(abs(v) for v in out.raw.values()) <= 1e-6
        assert len(out.displacements) == 136 and max(map(abs, out.displacements)) <= 1e-9
        assert max(map(abs, out.deltas)) <= 1e-9


def test_held_expression_holds_still() -> None:
    processor = FeatureProcessor()
    _neutral_second(processor)
    outs = _feed(processor, [(RIGHT_BROW_RAISED, IRIS)] * 60, FPS + 1)
    for out in outs[1:]:
        assert out.named == outs[0].named and out.raw == outs[0].raw


def test_brow_raise_through_the_processor() -> None:
    processor = FeatureProcessor()
    _neutral_second(processor)
    [out] = _feed(processor, [transform(RIGHT_BROW_RAISED, IRIS, yaw=15.0, roll=-10.0)], FPS + 1)
    assert out.raw["brow_raise_inner_right"] == pytest.approx(0.05, abs=1e-6)
    brow_max = BY_NAME["brow_raise_inner_right"].default_max
    assert out.named["brow_raise_inner_right"] == pytest.approx(0.05 / brow_max, abs=1e-5)
    assert out.raw["head_yaw"] == pytest.approx(15.0, abs=1e-6)
    assert out.named["head_yaw"] == pytest.approx(15.0 / BY_NAME["head_yaw"].default_max, abs=1e-6)
    roll_min = BY_NAME["head_roll"].default_min
    assert out.named["head_roll"] == pytest.approx(-10.0 / -roll_min, abs=1e-6)
    assert abs(out.raw["brow_raise_inner_left"]) < 1e-6
    # displacements are the 2D eye-corner frame's (the paper's): the right brow points go up
    disp = np.asarray(out.displacements).reshape(68, 2)
    assert np.all(disp[17:22, 1] > 0.01)


def test_displacements_are_per_point_movement_y_up() -> None:
    processor = FeatureProcessor()
    _neutral_second(processor)
    [out] = _feed(processor, [(RIGHT_BROW_RAISED, IRIS)], FPS + 1)
    disp = np.asarray(out.displacements).reshape(68, 2)
    np.testing.assert_allclose(disp[17:22], [[0.0, 0.05]] * 5, atol=1e-9)
    np.testing.assert_allclose(np.delete(disp, range(17, 22), axis=0), 0.0, atol=1e-9)


def test_points_without_mesh_give_the_2d_features() -> None:
    processor = FeatureProcessor()
    frames = [
        points_message(None, None, ibug=ibug_of(MESH), t_media_ns=i * S // FPS)
        for i in range(FPS + 2)
    ]
    outs = [processor.process(f) for f in frames]
    assert set(outs[-1].named) == set(LANDMARK_NAMES) - MESH_ONLY - set(GAZE)


def test_mesh_without_depth_is_ignored() -> None:
    processor = FeatureProcessor()
    outs = [
        processor.process(points_message(MESH, IRIS, t_media_ns=i * S // FPS, mesh_dims=2))
        for i in range(FPS + 2)
    ]
    assert "head_yaw" not in outs[-1].named and "gaze_left_x" in outs[-1].named


def test_frame_without_mesh_after_a_mesh_neutral_has_no_named_features() -> None:
    processor = FeatureProcessor()
    _neutral_second(processor)
    out = processor.process(points_message(None, IRIS, ibug=ibug_of(MESH), t_media_ns=2 * S))
    assert out.named == {} and out.raw == {} and len(out.deltas) == 68
    assert len(out.displacements) == 136


@pytest.mark.parametrize(
    ("sets", "message"),
    [
        ([PointSet(scheme="mesh468", dims=3, coords=[1.0] * 1401)], "mesh468 set has 1401 values"),
        ([PointSet(scheme="iris10", dims=2, coords=[1.0] * 18)], "iris10 set has 18 values"),
        ([PointSet(scheme="iris10", dims=2, coords=[float("nan")] * 20)], "not a finite number"),
    ],
    ids=["mesh-count", "iris-count", "iris-nan"],
)
def test_malformed_optional_sets_raise(sets, message) -> None:
    points = points_message(None, None, ibug=ibug_of(MESH))
    points.sets.extend(sets)
    with pytest.raises(FeatureError, match=message):
        FeatureProcessor().process(points)


def test_a_degenerate_mesh_is_left_out_of_the_neutral() -> None:
    ibug = ibug_of(MESH)
    collapsed = MESH.copy()
    collapsed[list(STABLE_VERTICES)] = collapsed[1]  # nothing to align on
    good = Sample(ibug, normalise(ibug), MESH, IRIS)
    neutral = neutral_face([Sample(ibug, normalise(ibug), collapsed, IRIS), good, good])
    assert neutral.reference is not None
    np.testing.assert_allclose(neutral.reference.mesh, MESH, atol=1e-9)
    assert neutral.named["jaw_open"] == pytest.approx(
        raw_features(ibug, MESH, IRIS, MESH)["jaw_open"]
    )


def test_no_face_gives_no_named_features() -> None:
    processor = FeatureProcessor()
    _neutral_second(processor)
    out = processor.process(points_message(face=False, seq=99, t_media_ns=5 * S))
    assert out == Features(
        seq=99, t_capture_ns=1099, t_media_ns=5 * S, face=False, neutral_ready=True
    )


# --- blink and wink through the processor ---------------------------------------------------


def _close(mesh: np.ndarray, side: str) -> np.ndarray:
    upper = EYE_CONTOUR_VERTICES[0 if side == "right" else 1][9:]
    ibug_upper = LID_UPPER[side].mesh
    lower = [144, 145, 153] if side == "right" else [373, 374, 380]
    gap = (mesh[lower, 1].mean() - mesh[list(ibug_upper), 1].mean()) / 150.0
    return move(mesh, upper, dy=-gap)


def test_wink_gives_the_closed_eye_the_open_eyes_gaze() -> None:
    processor = FeatureProcessor()
    _neutral_second(processor)
    looking = look(MESH, look(MESH, IRIS, "left", 0.06, 0.03), "right", -0.3, -0.2)  # junk right
    [out] = _feed(processor, [(_close(MESH, "right"), looking)], FPS + 1)
    assert out.raw["eye_open_right"] < -0.2 and abs(out.raw["eye_open_left"]) < 1e-9
    for axis, value in (("x", 0.06), ("y", 0.03)):
        assert out.raw[f"gaze_left_{axis}"] == pytest.approx(value, abs=0.005)
        assert out.raw[f"gaze_right_{axis}"] == out.raw[f"gaze_left_{axis}"]


def test_blink_holds_the_last_gaze() -> None:
    processor = FeatureProcessor()
    _neutral_second(processor)
    up = look(MESH, look(MESH, IRIS, "left", 0.0, 0.05), "right", 0.0, 0.05)
    junk = look(MESH, look(MESH, IRIS, "left", 0.2, -0.2), "right", -0.2, -0.2)
    shut = _close(_close(MESH, "right"), "left")
    outs = _feed(processor, [(MESH, up), (shut, junk), (shut, junk), (MESH, IRIS)], FPS + 1)
    for out in outs[:3]:
        for key in GAZE:
            assert out.raw[key] == outs[0].raw[key]
        assert out.raw["gaze_right_y"] == pytest.approx(0.05, abs=0.005)
        assert out.raw["gaze_left_y"] == pytest.approx(0.05, abs=0.005)
    assert outs[1].raw["eye_open_left"] < -0.2
    assert abs(outs[3].raw["gaze_right_y"]) < 1e-9, "eyes open again: live gaze"


# --- calibrations ---------------------------------------------------------------------------


def _calibration(**named) -> Calibration:
    ibug = ibug_of(MESH)
    neutral_raw = raw_features(ibug, MESH, IRIS, MESH)
    return Calibration(
        name="synthetic",
        neutral=nose_distances(normalise(ibug)).tolist(),
        delta_min=[-0.1] * 68,
        delta_max=[0.1] * 68,
        named_neutral={k: v for k, v in neutral_raw.items() if not k.startswith("head_")},
        neutral_mesh=MESH.ravel().tolist(),
        **named,
    )


@pytest.mark.parametrize("factory", ["classmethod", "kwarg"])
def test_a_full_calibration_gives_named_features_from_the_first_frame(factory: str) -> None:
    calibration = _calibration(
        named_min={"brow_raise_inner_right": -0.01}, named_max={"brow_raise_inner_right": 0.1}
    )
    if factory == "classmethod":
        processor = FeatureProcessor.from_calibration(calibration)
    else:
        processor = FeatureProcessor(calibration=calibration)
    outs = _feed(processor, [(RIGHT_BROW_RAISED, IRIS)] * (FPS + 1))
    first = outs[0]
    assert first.neutral_ready and len(first.deltas) == 68
    assert first.named["brow_raise_inner_right"] == pytest.approx(0.5, abs=1e-6)  # 0.05 / 0.1
    assert first.named["brow_raise_outer_right"] == pytest.approx(0.05 / 0.08, abs=1e-6)
    assert first.named["head_yaw"] == pytest.approx(0.0, abs=1e-9)
    # displacements need the neutral 68 points, which a calibration does not hold: measured
    # over the first second like the rest of a missing neutral
    assert first.displacements == [] and len(outs[-1].displacements) == 136


def test_an_old_calibration_gets_the_named_neutral_from_the_stream() -> None:
    calibration = _calibration()
    calibration.named_neutral = {}
    calibration.neutral_mesh = []
    processor = FeatureProcessor.from_calibration(calibration)
    outs = _feed(processor, [(MESH, IRIS)] * (FPS + 1) + [(RIGHT_BROW_RAISED, IRIS)])
    assert all(o.neutral_ready for o in outs)
    assert outs[0].named == {} and set(outs[FPS].named) == set(LANDMARK_NAMES)
    assert outs[-1].raw["brow_raise_inner_right"] == pytest.approx(0.05, abs=1e-6)


def test_calibrated_named_neutral_without_mesh_means_2d_features() -> None:
    ibug = ibug_of(MESH)
    calibration = _calibration()
    calibration.neutral_mesh = []
    calibration.named_neutral = raw_features(ibug)
    processor = FeatureProcessor.from_calibration(calibration)
    [out] = _feed(processor, [(RIGHT_BROW_RAISED, IRIS)])
    assert set(out.named) == set(LANDMARK_NAMES) - MESH_ONLY - set(GAZE)
    assert out.raw["brow_raise_inner_right"] == pytest.approx(0.05, abs=1e-6)


def test_neutral_face_of_samples() -> None:
    ibug = ibug_of(MESH)
    samples = [
        Sample(ibug_of(m), normalise(ibug_of(m)), m, i)
        for m, i in (transform(MESH, IRIS, yaw=a) for a in (-4.0, 0.0, 5.0))
    ]
    neutral = neutral_face(samples)
    assert neutral.reference is not None
    raw = raw_features(ibug, MESH, IRIS, neutral.reference)
    for name, value in raw.items():
        if not name.startswith("gaze_"):
            assert neutral.named[name] == pytest.approx(value, abs=1e-6), name
    with pytest.raises(FeatureError, match="no face frames"):
        neutral_face([])


def test_default_ranges_are_the_contracts() -> None:
    processor = FeatureProcessor()
    assert processor.ranges["jaw_open"] == (
        BY_NAME["jaw_open"].default_min,
        BY_NAME["jaw_open"].default_max,
    )


def test_head_pose_stays_relative_to_the_calibration_mesh_when_the_stream_starts_turned() -> None:
    # Regression: the first second's head pose used to become the neutral's, so a stream that
    # started turned read 0 degrees while turned and -12 degrees when facing the calibration.
    processor = FeatureProcessor.from_calibration(_calibration())
    turned = transform(MESH, IRIS, yaw=12.0)
    outs = _feed(processor, [turned] * (FPS + 5))
    assert outs[-1].neutral_ready
    assert outs[-1].raw["head_yaw"] == pytest.approx(12.0, abs=0.5)
    [facing] = _feed(processor, [(MESH, IRIS)], FPS + 5)
    assert abs(facing.raw["head_yaw"]) < 0.5
