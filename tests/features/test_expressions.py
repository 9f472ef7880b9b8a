"""services.features.expressions: every named feature on a real face with known synthetic motion.

The neutral is the sample video's first second (``synthetic_face``). Each edit moves known
landmarks by a known amount in the face frame (IOD units, y up); the features that should move
must move by the expected amount, in the right direction, and every other feature must stay
within 10% of the motion (cross-talk), both from the 3D mesh and from the 68 points alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from synthetic_face import IRIS, MESH, ibug_of, look, look_3d, move, to_face_frame, transform

from facesynth.runtime.feature_names import BY_NAME, LANDMARK_NAMES, SCALED_LIMIT
from facesynth.services.features.expressions import (
    BROW,
    BROW_INNER,
    CHEEK,
    LID_LOWER,
    LID_UPPER,
    LIP_CORNER,
    MESH_ONLY,
    default_ranges,
    face_frame_2d,
    ranges_from,
    raw_features,
    relative,
    scale,
    scale_value,
)
from facesynth.services.features.frame import FeatureError
from facesynth.services.features.pose import MeshReference
from facesynth.services.points.tracker.iris import EYE_CONTOUR_VERTICES

REFERENCE = MeshReference(MESH)
CANON = to_face_frame(MESH)
ALL_SIDES = ("right", "left")


def _raw(mesh: np.ndarray, iris: np.ndarray, use_mesh: bool) -> dict[str, float]:
    if use_mesh:
        return raw_features(ibug_of(mesh), mesh, iris, REFERENCE)
    return raw_features(ibug_of(mesh), None, iris)


def _rel(mesh: np.ndarray, iris: np.ndarray = IRIS, use_mesh: bool = True) -> dict[str, float]:
    return relative(_raw(mesh, iris, use_mesh), _raw(MESH, IRIS, use_mesh))


def _mean_y(vertices) -> float:
    return float(CANON[list(vertices), 1].mean())


def _eye_width(side: str, use_mesh: bool) -> float:
    """Eye width in IOD: in 3D from the mesh, else in the image (the 68 points' frame)."""
    a, b = (33, 133) if side == "right" else (263, 362)
    if use_mesh:
        return float(np.linalg.norm(CANON[a] - CANON[b]))
    return float(np.linalg.norm(CANON[a, :2] - CANON[b, :2]))


# Whole eye contours (the mesh's upper and lower lid lines), per side.
UPPER_CONTOUR = {"right": EYE_CONTOUR_VERTICES[0][9:], "left": EYE_CONTOUR_VERTICES[1][9:]}
LOWER_CONTOUR = {"right": EYE_CONTOUR_VERTICES[0][1:8], "left": EYE_CONTOUR_VERTICES[1][1:8]}
LID_GAP = {
    side: _mean_y(LID_UPPER[side].mesh) - _mean_y(LID_LOWER[side].mesh) for side in ALL_SIDES
}
CORNERS = [61, 291, 78, 308]
#: MediaPipe's lower lip lines (outer and inner) without the corners.
LOWER_LIP = [146, 91, 181, 84, 17, 314, 405, 321, 375, 95, 88, 178, 87, 14, 317, 402, 318, 324]
#: What the jaw carries: the lower lip and everything below it (the corners move half as far).
BELOW_MOUTH = sorted(
    set(LOWER_LIP) | {int(v) for v in np.flatnonzero(CANON[:, 1] < CANON[LOWER_LIP, 1].min())}
)
OUT = {"right": -1.0, "left": 1.0}
INNER_LOWER_LIP = [14, 87, 317, 178, 402, 88, 318, 95, 324]


def _brow_raise(mesh: np.ndarray) -> np.ndarray:
    return move(mesh, BROW["right"].mesh, dy=0.05)


def _inner_brow_raise(mesh: np.ndarray) -> np.ndarray:
    return move(mesh, BROW_INNER["left"].mesh, dy=0.04)


def _frown(mesh: np.ndarray) -> np.ndarray:
    for side in ALL_SIDES:
        mesh = move(mesh, BROW[side].mesh, dy=-0.02)
        mesh = move(mesh, BROW_INNER[side].mesh, dx=-OUT[side] * 0.01)
    return mesh


def _close_right_eye(mesh: np.ndarray) -> np.ndarray:
    return move(mesh, UPPER_CONTOUR["right"], dy=-LID_GAP["right"])


def _lid_tighten(mesh: np.ndarray) -> np.ndarray:
    return move(mesh, LOWER_CONTOUR["left"], dy=0.02)


def _cheek_raise(mesh: np.ndarray) -> np.ndarray:
    return move(mesh, CHEEK["right"].mesh, dy=0.03)


def _smile(mesh: np.ndarray) -> np.ndarray:
    for side in ALL_SIDES:
        mesh = move(mesh, LIP_CORNER[side].mesh, dx=OUT[side] * 0.03, dy=0.03)
    return mesh


def _depress(mesh: np.ndarray) -> np.ndarray:
    return move(mesh, CORNERS, dy=-0.03)


def _jaw_open(mesh: np.ndarray) -> np.ndarray:
    return move(move(mesh, BELOW_MOUTH, dy=-0.1), CORNERS, dy=-0.05)


def _lips_part(mesh: np.ndarray) -> np.ndarray:
    return move(mesh, INNER_LOWER_LIP, dy=-0.03)


def _pucker(mesh: np.ndarray) -> np.ndarray:
    for side in ALL_SIDES:
        mesh = move(mesh, LIP_CORNER[side].mesh, dx=-OUT[side] * 0.03)
    return mesh


R2 = math.sqrt(2.0)
Expected = dict[str, float | Callable[[bool], float]]
EDITS: list[tuple[str, Callable[[np.ndarray], np.ndarray], Expected, float]] = [
    # (id, edit, expected relative values (or a function of use_mesh), size of the motion for
    # the cross-talk bound)
    (
        "raise-right-brow",
        _brow_raise,
        {
            "brow_raise_inner_right": 0.05,
            "brow_raise_outer_right": 0.05,
            "brow_lower_right": -0.05,
        },
        0.05,
    ),
    (
        "raise-left-inner-brow",
        _inner_brow_raise,
        {"brow_raise_inner_left": 0.04, "brow_lower_left": -0.016},
        0.04,
    ),
    (
        "frown",
        _frown,
        {
            **{f"brow_lower_{s}": 0.03 for s in ALL_SIDES},
            **{f"brow_raise_inner_{s}": -0.02 for s in ALL_SIDES},
            **{f"brow_raise_outer_{s}": -0.02 for s in ALL_SIDES},
        },
        0.02,
    ),
    (
        "close-right-eye",
        _close_right_eye,
        {"eye_open_right": lambda mesh: -LID_GAP["right"] / _eye_width("right", mesh)},
        0.1,
    ),
    (
        "tighten-left-lid",
        _lid_tighten,
        {"lid_tighten_left": 0.02, "eye_open_left": lambda mesh: -0.02 / _eye_width("left", mesh)},
        0.02,
    ),
    ("raise-right-cheek", _cheek_raise, {"cheek_raise_right": 0.03}, 0.03),
    (
        "smile",
        _smile,
        {
            "lip_corner_pull_right": 0.06 / R2,
            "lip_corner_pull_left": 0.06 / R2,
            "lip_pucker": -0.06,
        },
        0.03,
    ),
    (
        "depress",
        _depress,
        {
            **{f"lip_corner_depress_{s}": 0.03 / R2 for s in ALL_SIDES},
            **{f"lip_corner_pull_{s}": -0.03 / R2 for s in ALL_SIDES},
        },
        0.03,
    ),
    ("jaw-open", _jaw_open, {"jaw_open": 0.1, "lips_part": 0.1}, 0.1),
    ("lips-part", _lips_part, {"lips_part": 0.03}, 0.03),
    (
        "pucker",
        _pucker,
        {
            "lip_pucker": 0.06,
            **{f"lip_corner_pull_{s}": -0.03 / R2 for s in ALL_SIDES},
            **{f"lip_corner_depress_{s}": -0.03 / R2 for s in ALL_SIDES},
        },
        0.03,
    ),
]
EDIT_IDS = [e[0] for e in EDITS]


@pytest.mark.parametrize("use_mesh", [True, False], ids=["mesh", "ibug68-only"])
@pytest.mark.parametrize(("name", "edit", "expected", "size"), EDITS, ids=EDIT_IDS)
def test_known_motion_moves_the_right_features(use_mesh, name, edit, expected, size) -> None:
    rel = _rel(edit(MESH.copy()), use_mesh=use_mesh)
    if not use_mesh:  # the 68 points have no cheek (nor head yaw and pitch)
        assert not MESH_ONLY & set(rel)
        expected = {k: v for k, v in expected.items() if k not in MESH_ONLY}
    for feature, value in expected.items():
        want = value(use_mesh) if callable(value) else value
        assert rel[feature] == pytest.approx(want, abs=1e-6), feature
    crosstalk = {k: v for k, v in rel.items() if k not in expected and abs(v) >= 0.1 * size}
    assert crosstalk == {}


def test_neutral_reads_zero() -> None:
    for use_mesh in (True, False):
        rel = _rel(MESH.copy(), use_mesh=use_mesh)
        assert max(abs(v) for v in rel.values()) < 1e-9


def test_features_each_input_supports() -> None:
    ibug = ibug_of(MESH)
    full = raw_features(ibug, MESH, IRIS, REFERENCE)
    assert set(full) == set(LANDMARK_NAMES)
    no_iris = raw_features(ibug, MESH, None, MESH)  # a plain array as neutral mesh works too
    assert set(no_iris) == {n for n in LANDMARK_NAMES if not n.startswith("gaze_")}
    flat = raw_features(ibug, None, IRIS)
    assert set(flat) == set(LANDMARK_NAMES) - MESH_ONLY
    gaze = {n for n in LANDMARK_NAMES if "gaze" in n}
    assert set(raw_features(ibug)) == set(LANDMARK_NAMES) - MESH_ONLY - gaze
    own_frame = raw_features(ibug, MESH, IRIS)  # no neutral mesh: own frame, pose vs camera
    for name, value in full.items():
        assert own_frame[name] == pytest.approx(value, abs=1e-9), name


POSES = [
    dict(yaw=20.0),
    dict(yaw=-30.0),
    dict(pitch=15.0),
    dict(pitch=-20.0),
    dict(roll=25.0),
    dict(yaw=18.0, pitch=-12.0, roll=9.0, scale=0.7, shift=(40.0, -25.0, 10.0)),
]
POSE_IDS = ["yaw20", "yaw-30", "pitch15", "pitch-20", "roll25", "all"]


@pytest.mark.parametrize("pose", POSES, ids=POSE_IDS)
def test_rotated_head_reads_its_angles_and_no_expression(pose) -> None:
    mesh, iris = transform(MESH, IRIS, **pose)
    rel = _rel(mesh, iris)
    for axis in ("yaw", "pitch", "roll"):
        assert rel[f"head_{axis}"] == pytest.approx(pose.get(axis, 0.0), abs=1e-6)
    expressions = {k: v for k, v in rel.items() if not k.startswith(("head_", "gaze_"))}
    assert max(abs(v) for v in expressions.values()) < 1e-6


@pytest.mark.parametrize("pose", POSES, ids=POSE_IDS)
@pytest.mark.parametrize(("name", "edit", "expected", "size"), EDITS, ids=EDIT_IDS)
def test_expression_on_a_turned_head_reads_as_on_a_straight_one(
    pose, name, edit, expected, size
) -> None:
    mesh, iris = transform(edit(MESH.copy()), IRIS, **pose)
    rel = _rel(mesh, iris)
    for feature, value in expected.items():
        want = value(True) if callable(value) else value
        assert rel[feature] == pytest.approx(want, abs=1e-6), feature


def test_head_turn_reads_as_expression_without_the_mesh() -> None:
    """Why the mesh matters: in 2D a 25-degree turn shifts features, in 3D it does not."""
    mesh, iris = transform(MESH, IRIS, yaw=25.0)
    flat = _rel(mesh, iris, use_mesh=False)
    full = _rel(mesh, iris, use_mesh=True)
    assert "head_yaw" not in flat
    expression = [n for n in full if not n.startswith(("head_", "gaze_"))]
    assert max(abs(full[n]) for n in expression) < 1e-6
    assert max(abs(flat[n]) for n in expression if n in flat) > 0.01


@pytest.mark.parametrize(
    ("roll", "scale", "shift"),
    [(20.0, 1.0, (0.0, 0.0, 0.0)), (-35.0, 0.5, (100.0, 30.0, 0.0)), (0.0, 2.0, (-60.0, 0.0, 0.0))],
    ids=["roll20", "roll-35-half", "double"],
)
def test_2d_features_ignore_in_plane_motion(roll, scale, shift) -> None:
    mesh, iris = transform(
        _smile(_brow_raise(MESH.copy())), IRIS, roll=roll, scale=scale, shift=shift
    )
    moved = _rel(mesh, iris, use_mesh=False)
    still = _rel(_smile(_brow_raise(MESH.copy())), IRIS, use_mesh=False)
    assert moved["head_roll"] == pytest.approx(roll, abs=1e-6)
    for name, value in still.items():
        if name != "head_roll":
            assert moved[name] == pytest.approx(value, abs=1e-6), name


@pytest.mark.parametrize("use_mesh", [True, False], ids=["mesh", "ibug68-only"])
@pytest.mark.parametrize(
    ("side", "dx", "dy"),
    [("right", 0.1, 0.0), ("left", 0.0, 0.06), ("right", -0.08, -0.05)],
    ids=["right-looks-left", "left-looks-up", "right-looks-down-right"],
)
def test_shifted_iris_moves_that_eyes_gaze_only(use_mesh, side, dx, dy) -> None:
    shifted = (look_3d if use_mesh else look)(MESH, IRIS, side, dx, dy)
    rel = _rel(MESH.copy(), shifted, use_mesh=use_mesh)
    assert rel[f"gaze_{side}_x"] == pytest.approx(dx, abs=1e-9)
    assert rel[f"gaze_{side}_y"] == pytest.approx(dy, abs=1e-9)
    others = {k: v for k, v in rel.items() if not k.startswith(f"gaze_{side}")}
    assert max(abs(v) for v in others.values()) < 1e-9


@pytest.mark.parametrize("use_mesh", [True, False], ids=["mesh", "ibug68-only"])
@pytest.mark.parametrize(
    "pose",
    [dict(yaw=15.0), dict(yaw=-15.0), dict(pitch=-12.0), dict(pitch=12.0), dict(roll=20.0)],
    ids=["yaw", "yaw-", "pitch", "pitch-", "roll"],
)
def test_head_turn_with_eyes_fixed_in_the_head_is_not_gaze(use_mesh, pose) -> None:
    """Eyes that turn with the head (iris fixed in the eye's opening) keep their gaze when it
    is read in the face frame. In the image the iris, in front of the eye corners, shifts
    against them by up to 0.035 eye width for these turns; in-plane roll is free of it."""
    mesh, iris = transform(MESH, IRIS, **pose)
    rel = _rel(mesh, iris, use_mesh=use_mesh)
    worst = max(abs(rel[k]) for k in rel if k.startswith("gaze_"))
    if use_mesh or "roll" in pose:
        assert worst < 1e-6
    else:
        assert 0.01 < worst < 0.05


def test_face_frame_2d_points_up() -> None:
    frame = face_frame_2d(ibug_of(MESH))
    np.testing.assert_allclose(frame[36], [-0.5, 0.0], atol=1e-12)
    assert frame[19, 1] > 0 > frame[8, 1], "brow above the eye line, chin below"


def test_degenerate_inputs_raise_feature_error() -> None:
    ibug = ibug_of(MESH)
    collapsed = ibug.copy()
    collapsed[45] = collapsed[36]
    with pytest.raises(FeatureError, match="no face frame"):
        raw_features(collapsed)
    flat_mesh = MESH.copy()
    flat_mesh[263] = flat_mesh[33]
    with pytest.raises(FeatureError):
        raw_features(ibug, flat_mesh, IRIS)


# --- relative and scaling -------------------------------------------------------------------


def test_relative_needs_a_neutral_except_for_head_pose() -> None:
    raw = {"head_yaw": 5.0, "head_roll": 2.0, "jaw_open": 0.3, "lips_part": 0.1}
    neutral = {"head_roll": 1.0, "jaw_open": 0.2}
    assert relative(raw, neutral) == pytest.approx(
        {"head_yaw": 5.0, "head_roll": 1.0, "jaw_open": 0.1}
    )


@pytest.mark.parametrize(
    ("value", "lo", "hi", "expected"),
    [
        (0.0, -0.03, 0.08, 0.0),
        (0.04, -0.03, 0.08, 0.5),
        (0.08, -0.03, 0.08, 1.0),
        (-0.03, -0.03, 0.08, -1.0),
        (-0.015, -0.03, 0.08, -0.5),
        (0.5, -0.03, 0.08, SCALED_LIMIT),
        (-0.5, -0.03, 0.08, -SCALED_LIMIT),
        (0.1, -0.03, 0.08, 1.25),
    ],
    ids=["zero", "half-up", "max", "min", "half-down", "clamp-up", "clamp-down", "beyond"],
)
def test_scale_value_table(value, lo, hi, expected) -> None:
    assert scale_value(value, lo, hi) == pytest.approx(expected)


def test_ranges_come_from_the_calibration_where_given() -> None:
    ranges = ranges_from({"jaw_open": -0.01}, {"jaw_open": 0.5, "lips_part": 0.2})
    assert ranges["jaw_open"] == (-0.01, 0.5)
    assert ranges["lips_part"] == (BY_NAME["lips_part"].default_min, 0.2)
    assert ranges["head_yaw"] == default_ranges()["head_yaw"] == (-30.0, 30.0)
    assert scale({"jaw_open": 0.25, "head_yaw": -15.0}, ranges) == pytest.approx(
        {"jaw_open": 0.5, "head_yaw": -0.5}
    )


def test_scale_is_scale_value_of_every_feature() -> None:
    """``scale`` writes ``scale_value`` out in its loop: the same value for every input, the
    ends, both signs of zero, infinities and NaN included (bit for bit, NaN as NaN's min/max)."""
    values = [0.0, -0.0, 0.04, -0.015, 0.08, -0.03, 0.5, -0.5, math.inf, -math.inf, math.nan]
    rel = {f"f{i}": value for i, value in enumerate(values)}
    ranges = {name: (-0.03, 0.08) for name in rel}
    scaled = scale(rel, ranges)
    assert list(scaled) == list(rel)
    for name, value in rel.items():
        want = scale_value(value, -0.03, 0.08)
        assert math.copysign(1.0, scaled[name]) == math.copysign(1.0, want), name
        assert scaled[name] == want or (math.isnan(scaled[name]) and math.isnan(want)), name
