"""services.features.core: the paper's pose-free features (section 2.2.2) and the neutral face."""

from __future__ import annotations

import math
from importlib import resources

import msgspec
import numpy as np
import pytest

from facesynth.runtime import codec
from facesynth.runtime.landmarks import LEFT_EYE_OUTER, NOSE_TIP, RIGHT_EYE_OUTER
from facesynth.schemas.messages import Features, Points, PointSet
from facesynth.services.features.core import (
    FeatureError,
    FeatureProcessor,
    NeutralEstimator,
    normalise,
    nose_distances,
)
from facesynth.services.features.point_sets import ibug_points
from facesynth.services.points.openface_csv import load_openface_csv

S = 1_000_000_000
RIGHT_BROW = list(range(17, 22))


def _mean_shape() -> np.ndarray:
    """The mean of the 100 real OpenFace frames shipped with facesynth, (68, 2) pixels."""
    path = resources.files("facesynth.app.data") / "OpenFace_Test.csv"
    with resources.as_file(path) as file:
        rows = load_openface_csv(file)
    return np.mean([row.points for row in rows], axis=0)


SHAPE = _mean_shape()
FRAME = normalise(SHAPE)


def _similarity(points: np.ndarray, angle_deg: float, scale: float, shift: tuple[float, float]):
    theta = math.radians(angle_deg)
    rotation = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    return scale * points @ rotation.T + np.asarray(shift)


def _points_message(
    pixels: np.ndarray, *, seq: int = 0, t_media_ns: int = 0, face: bool = True, dims: int = 2
) -> Points:
    array = pixels if dims == 2 else np.column_stack([pixels, np.full(len(pixels), 7.0)])
    sets = [PointSet(scheme="ibug68", dims=dims, coords=array.ravel().tolist())] if face else []
    return Points(
        seq=seq,
        t_capture_ns=1000 + seq,
        t_media_ns=t_media_ns,
        face=face,
        confidence=0.9,
        image_width=640,
        image_height=360,
        sets=sets,
    )


TRANSFORMS = [
    (0.0, 1.0, (0.0, 0.0)),
    (0.0, 1.0, (250.0, -80.0)),
    (15.0, 1.0, (0.0, 0.0)),
    (-30.0, 1.0, (10.0, 10.0)),
    (90.0, 1.0, (300.0, 20.0)),
    (180.0, 1.0, (0.0, 0.0)),
    (-135.0, 1.0, (5.0, 5.0)),
    (0.0, 0.25, (0.0, 0.0)),
    (0.0, 3.7, (-100.0, 40.0)),
    (47.0, 0.6, (1000.0, 2000.0)),
]
TRANSFORM_IDS = [
    "identity",
    "translate",
    "rot15",
    "rot-30",
    "rot90",
    "rot180",
    "rot-135",
    "scale0.25",
    "scale3.7-translate",
    "all-three",
]


# --- normalise / nose_distances --------------------------------------------------------------


@pytest.mark.parametrize(("angle", "scale", "shift"), TRANSFORMS, ids=TRANSFORM_IDS)
def test_normalise_removes_translation_rotation_and_scale(angle, scale, shift) -> None:
    moved = _similarity(SHAPE, angle, scale, shift)
    if (angle, scale, shift) != (0.0, 1.0, (0.0, 0.0)):
        assert not np.allclose(moved, SHAPE)  # the transform really moved the face
    np.testing.assert_allclose(normalise(moved), FRAME, rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        nose_distances(normalise(moved)), nose_distances(FRAME), rtol=0, atol=1e-9
    )


def test_face_frame_is_the_eye_line() -> None:
    np.testing.assert_allclose(FRAME[RIGHT_EYE_OUTER], [-0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(FRAME[LEFT_EYE_OUTER], [0.5, 0.0], atol=1e-12)
    # Not a mirror image: brows above the eye line (negative y, as in the image), nose and chin
    # below, the performer's right brow on the image's left.
    assert np.all(FRAME[17:27, 1] < 0)
    assert FRAME[NOSE_TIP, 1] > 0 and FRAME[8, 1] > FRAME[NOSE_TIP, 1]
    assert np.all(FRAME[17:22, 0] < 0) and np.all(FRAME[22:27, 0] > 0)


def test_nose_distances_are_distances_to_point_30() -> None:
    distances = nose_distances(FRAME)
    assert distances.shape == (68,)
    assert distances[NOSE_TIP] == 0.0
    for i in (0, 8, 19, 36, 45, 57):
        expected = math.dist(FRAME[i], FRAME[NOSE_TIP])
        assert distances[i] == pytest.approx(expected, abs=1e-12)
    # Unit = inter-ocular distance: the two outer eye corners are 1 apart.
    assert math.dist(FRAME[36], FRAME[45]) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("raise_by", [0.01, 0.05, 0.2], ids=["0.01", "0.05", "0.2"])
@pytest.mark.parametrize(("angle", "scale", "shift"), TRANSFORMS[2:5], ids=TRANSFORM_IDS[2:5])
def test_raised_brow_increases_its_nose_distances(raise_by, angle, scale, shift) -> None:
    raised = FRAME.copy()
    raised[RIGHT_BROW, 1] -= raise_by  # "up" is -y in the face frame
    pixels = _similarity(raised * 80.0, angle, scale, shift)
    got = nose_distances(normalise(pixels)) - nose_distances(FRAME)
    nose = FRAME[NOSE_TIP]
    for i in range(68):
        if i in RIGHT_BROW:
            expected = math.hypot(FRAME[i, 0] - nose[0], FRAME[i, 1] - raise_by - nose[1])
            expected -= math.dist(FRAME[i], nose)
            assert got[i] == pytest.approx(expected, abs=1e-9)
            assert got[i] > 0.5 * raise_by  # the brow is well above the nose: most of it shows
        else:
            assert got[i] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize(
    ("first", "second"),
    [
        ((100.0, 100.0), (100.0, 100.0)),
        ((100.0, 100.0), (100.0 + 1e-4, 100.0)),
        ((100.0, 100.0), (math.nan, 100.0)),
        ((math.inf, 0.0), (100.0, 100.0)),
    ],
    ids=["same-point", "1e-4-px", "nan", "inf"],
)
def test_degenerate_eye_corners(first, second) -> None:
    pixels = SHAPE.copy()
    pixels[RIGHT_EYE_OUTER] = first
    pixels[LEFT_EYE_OUTER] = second
    with pytest.raises(FeatureError, match=r"outer eye corners are .* px apart: no face frame"):
        normalise(pixels)


# --- ibug_points ------------------------------------------------------------------------------


def test_ibug_points_2d_and_3d() -> None:
    np.testing.assert_array_equal(ibug_points(_points_message(SHAPE)), SHAPE)
    np.testing.assert_array_equal(ibug_points(_points_message(SHAPE, dims=3)), SHAPE)


def test_ibug_points_found_among_other_sets() -> None:
    message = _points_message(SHAPE)
    message.sets.insert(0, PointSet(scheme="iris10", dims=2, coords=[0.0] * 20))
    np.testing.assert_array_equal(ibug_points(message), SHAPE)


@pytest.mark.parametrize(
    ("sets", "detail"),
    [
        ([], "no ibug68 point set in the message (has: none)"),
        (
            [
                PointSet(scheme="mesh468", dims=3, coords=[0.0] * 1404),
                PointSet(scheme="iris10", dims=2, coords=[0.0] * 20),
            ],
            "no ibug68 point set in the message (has: mesh468, iris10)",
        ),
        ([PointSet(scheme="ibug68", dims=2, coords=[0.0] * 134)], "ibug68 set has 134 values"),
        ([PointSet(scheme="ibug68", dims=3, coords=[0.0] * 136)], "ibug68 set has 136 values"),
        ([PointSet(scheme="ibug68", dims=4, coords=[0.0] * 272)], "ibug68 set has 272 values"),
    ],
    ids=["no-sets", "other-schemes", "67-points", "2d-count-as-3d", "dims-4"],
)
def test_ibug_points_errors(sets: list[PointSet], detail: str) -> None:
    message = msgspec.structs.replace(_points_message(SHAPE), sets=sets)
    with pytest.raises(FeatureError) as info:
        ibug_points(message)
    assert str(info.value) == detail


# --- NeutralEstimator -------------------------------------------------------------------------


def test_neutral_is_the_median_of_the_first_second_from_the_first_face() -> None:
    estimator = NeutralEstimator(1.0)
    start = 5 * S  # media time does not start at the first face
    results = []
    for i in range(15):  # 10 Hz, value i at 0.1 s * i
        results.append(estimator.add(start + i * S // 10, np.full(68, float(i))))
    # Frames at 0.0 .. 0.9 s are the neutral window; the one at 1.0 s completes it.
    assert results == [False] * 10 + [True] * 5
    assert estimator.ready
    np.testing.assert_array_equal(estimator.neutral, np.full(68, 4.5))  # median of 0..9


@pytest.mark.parametrize(
    ("seconds", "times_ms", "values", "neutral"),
    [
        (0.5, [0, 100, 200, 300, 400, 500], [1, 9, 2, 8, 3, 100], 3.0),
        (1.0, [0, 999, 1000], [1, 3, 100], 2.0),
        (1.0, [0, 5000], [7, 100], 7.0),
        (2.0, [0, 500, 1000, 1500, 1999, 2000], [4, 4, 4, 0, 9, 100], 4.0),
    ],
    ids=["half-second", "edge-999ms-in-1000ms-out", "one-sample-then-gap", "two-seconds"],
)
def test_neutral_window_table(seconds, times_ms, values, neutral) -> None:
    estimator = NeutralEstimator(seconds)
    for t_ms, value in zip(times_ms[:-1], values[:-1], strict=True):
        assert estimator.add(t_ms * 1_000_000, np.full(68, float(value))) is False
    assert estimator.add(times_ms[-1] * 1_000_000, np.full(68, float(values[-1]))) is True
    np.testing.assert_array_equal(estimator.neutral, np.full(68, neutral))


def test_neutral_is_per_feature_median_and_frozen() -> None:
    estimator = NeutralEstimator(1.0)
    estimator.add(0, np.arange(68.0))
    estimator.add(S // 2, np.arange(68.0) * 3)
    estimator.add(S // 3, np.arange(68.0) * 2)
    estimator.add(S, np.zeros(68))
    np.testing.assert_array_equal(estimator.neutral, np.arange(68.0) * 2)
    estimator.add(2 * S, np.full(68, 1000.0))  # later frames never change it
    np.testing.assert_array_equal(estimator.neutral, np.arange(68.0) * 2)


def test_neutral_samples_are_copies() -> None:
    estimator = NeutralEstimator(1.0)
    values = np.ones(68)
    estimator.add(0, values)
    values[:] = 50.0  # the caller reuses its buffer
    estimator.add(S, values)
    np.testing.assert_array_equal(estimator.neutral, np.ones(68))


@pytest.mark.parametrize("seconds", [0.0, -1.0, math.nan], ids=["zero", "negative", "nan"])
def test_neutral_window_must_be_positive(seconds: float) -> None:
    with pytest.raises(ValueError, match="longer than zero seconds"):
        NeutralEstimator(seconds)


# --- FeatureProcessor -------------------------------------------------------------------------


def test_no_face_in_no_face_out() -> None:
    processor = FeatureProcessor()
    out = processor.process(_points_message(SHAPE, seq=4, t_media_ns=77, face=False))
    assert out == Features(seq=4, t_capture_ns=1004, t_media_ns=77, face=False, neutral_ready=False)
    assert out.distances == [] and out.deltas == []
    assert codec.decode(codec.encode(out), Features) == out


def test_no_face_frames_do_not_start_the_neutral_window() -> None:
    processor = FeatureProcessor(neutral_seconds=1.0)
    for i in range(30):  # 3 s without a face
        assert not processor.process(
            _points_message(SHAPE, seq=i, t_media_ns=i * S // 10, face=False)
        ).neutral_ready
    outs = [
        processor.process(_points_message(SHAPE, seq=30 + i, t_media_ns=(30 + i) * S // 10))
        for i in range(11)
    ]
    assert [o.neutral_ready for o in outs] == [False] * 10 + [True]
    assert all(o.deltas == [] for o in outs[:10])
    np.testing.assert_allclose(outs[10].deltas, 0.0, atol=1e-12)
    no_face = processor.process(_points_message(SHAPE, seq=99, t_media_ns=10 * S, face=False))
    assert no_face.face is False and no_face.neutral_ready is True


def test_features_of_a_face_with_a_known_neutral() -> None:
    neutral = nose_distances(FRAME)
    processor = FeatureProcessor(neutral=neutral)
    raised = FRAME.copy()
    raised[RIGHT_BROW, 1] -= 0.05
    message = _points_message(
        _similarity(raised * 90, 20.0, 1.0, (320, 180)), seq=9, t_media_ns=123
    )
    out = processor.process(message)
    assert (out.seq, out.t_capture_ns, out.t_media_ns) == (9, 1009, 123)
    assert out.face and out.neutral_ready
    assert len(out.distances) == len(out.deltas) == 68
    deltas = np.asarray(out.deltas)
    np.testing.assert_allclose(deltas, np.asarray(out.distances) - neutral, atol=1e-12)
    assert np.all(deltas[RIGHT_BROW] > 0.025)
    np.testing.assert_allclose(np.delete(deltas, RIGHT_BROW), 0.0, atol=1e-9)
    assert codec.decode(codec.encode(out), Features) == out


@pytest.mark.parametrize(
    "neutral",
    [np.ones(67), np.ones((68, 2)), np.r_[np.ones(67), math.nan], np.r_[np.ones(67), math.inf]],
    ids=["67", "2d", "nan", "inf"],
)
def test_bad_neutral_is_refused(neutral: np.ndarray) -> None:
    with pytest.raises(FeatureError, match="a neutral needs 68 finite distances"):
        FeatureProcessor(neutral=neutral)


def test_unusable_points_raise_feature_error() -> None:
    processor = FeatureProcessor()
    mesh_only = [PointSet(scheme="mesh468", dims=3, coords=[0.0] * 1404)]
    message = msgspec.structs.replace(_points_message(SHAPE), sets=mesh_only)
    with pytest.raises(FeatureError, match="no ibug68 point set"):
        processor.process(message)
    collapsed = SHAPE.copy()
    collapsed[LEFT_EYE_OUTER] = collapsed[RIGHT_EYE_OUTER]
    with pytest.raises(FeatureError, match="no face frame"):
        processor.process(_points_message(collapsed))
    assert not processor.estimator.ready  # unusable frames are not neutral samples
    assert processor.estimator._window.samples == []
