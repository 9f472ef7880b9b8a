"""facesynth.services.features.gaze: iris against the eye corners, and the blink/wink rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from synthetic_face import IRIS, MESH, ibug_of, look, look_3d, transform

from facesynth.services.features.gaze import (
    CLOSED_BELOW,
    GazeHold,
    _eye_frame_gaze,
    eye_gaze,
    gaze_features,
    gaze_features_3d,
    iris_depth,
)
from facesynth.services.features.pose import apply, own_frame


@pytest.mark.parametrize(
    ("iris", "a", "b", "expected"),
    [
        ((5.0, 0.0), (0.0, 0.0), (10.0, 0.0), (0.0, 0.0)),
        ((6.0, 0.0), (0.0, 0.0), (10.0, 0.0), (0.1, 0.0)),  # toward the performer's left
        ((4.0, 0.0), (0.0, 0.0), (10.0, 0.0), (-0.1, 0.0)),
        ((5.0, -1.0), (0.0, 0.0), (10.0, 0.0), (0.0, 0.1)),  # image y down: -y is up
        ((5.0, 2.0), (0.0, 0.0), (10.0, 0.0), (0.0, -0.2)),
        # the eye rolled by 90 degrees (image left corner above the right one)
        ((0.0, 6.0), (0.0, 0.0), (0.0, 10.0), (0.1, 0.0)),
        ((1.0, 5.0), (0.0, 0.0), (0.0, 10.0), (0.0, 0.1)),
        ((25.0, 0.0), (0.0, 0.0), (40.0, 0.0), (0.125, 0.0)),  # unit = this eye's width
    ],
    ids=["centre", "left", "right", "up", "down", "rolled-x", "rolled-up", "width"],
)
def test_eye_gaze_table(iris, a, b, expected) -> None:
    got = eye_gaze(np.array(iris), np.array(a), np.array(b))
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_eye_gaze_of_collapsed_corners_is_nan() -> None:
    assert all(math.isnan(v) for v in eye_gaze(np.ones(2), np.zeros(2), np.zeros(2)))


@pytest.mark.parametrize("use_mesh", [True, False], ids=["mesh-corners", "ibug-corners"])
@pytest.mark.parametrize(
    ("side", "dx", "dy"),
    [("right", 0.1, 0.0), ("right", 0.0, 0.08), ("left", -0.12, 0.0), ("left", 0.05, -0.06)],
    ids=["right-looks-left", "right-up", "left-looks-right", "left-down-left"],
)
def test_shifted_iris_reads_as_the_shift(use_mesh, side, dx, dy) -> None:
    moved = look(MESH, IRIS, side, dx, dy)
    ibug = ibug_of(MESH)
    before = gaze_features(IRIS, MESH if use_mesh else None, ibug)
    after = gaze_features(moved, MESH if use_mesh else None, ibug)
    other = "left" if side == "right" else "right"
    assert after[f"gaze_{side}_x"] - before[f"gaze_{side}_x"] == pytest.approx(dx, abs=1e-9)
    assert after[f"gaze_{side}_y"] - before[f"gaze_{side}_y"] == pytest.approx(dy, abs=1e-9)
    assert after[f"gaze_{other}_x"] == before[f"gaze_{other}_x"]
    assert after[f"gaze_{other}_y"] == before[f"gaze_{other}_y"]


@pytest.mark.parametrize("roll", [-20.0, 15.0])
def test_gaze_is_read_in_the_eye_frame_under_roll(roll: float) -> None:
    """An in-plane head tilt moves iris and corners together: gaze does not change."""
    mesh, iris = transform(MESH, IRIS, roll=roll)
    before = gaze_features(IRIS, MESH, ibug_of(MESH))
    after = gaze_features(iris, mesh, ibug_of(mesh))
    for key, value in before.items():
        assert after[key] == pytest.approx(value, abs=1e-9)


@pytest.mark.parametrize(
    "pose", [dict(), dict(yaw=20.0, pitch=-10.0, roll=5.0)], ids=["still", "turned"]
)
def test_3d_gaze_with_or_without_the_aligned_mesh(pose) -> None:
    mesh, iris = transform(MESH, look_3d(MESH, IRIS, "left", 0.05, -0.04), **pose)
    frame = own_frame(mesh)
    alone = gaze_features_3d(iris, mesh, frame)
    assert alone == gaze_features_3d(iris, mesh, frame, apply(frame, mesh))
    base = gaze_features_3d(IRIS, MESH, own_frame(MESH))
    assert alone["gaze_left_x"] - base["gaze_left_x"] == pytest.approx(0.05, abs=1e-9)
    assert alone["gaze_left_y"] - base["gaze_left_y"] == pytest.approx(-0.04, abs=1e-9)
    assert alone["gaze_right_x"] == pytest.approx(base["gaze_right_x"], abs=1e-9)


def test_iris_depth_of_an_edge_on_eye_is_its_plane_origin() -> None:
    """An eye whose opening is seen edge-on (head turned 90 degrees) has no depth to read."""
    a, b = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 10.0]])  # corner line along z
    depth = iris_depth(
        a,
        b,
        np.array([[0.0, 0.0, 5.0]]),
        np.array([0.0, -1.0, 0.0]),
        np.array([-1.0, 0.0, 0.0]),
        np.array([[3.0, 1.0]]),
    )
    assert depth[0] == pytest.approx(5.0)


# --- GazeHold ------------------------------------------------------------------------------

OPEN = 0.3  # absolute openness of an open eye; the neutral's is the same
SHUT = 0.05


def _step(hold: GazeHold, right: float, left: float, gaze: dict[str, float]) -> dict[str, float]:
    neutral = {"eye_open_right": OPEN, "eye_open_left": OPEN}
    return hold.update(gaze, {"eye_open_right": right, "eye_open_left": left}, neutral)


def _gaze(rx: float, ry: float, lx: float, ly: float) -> dict[str, float]:
    return {"gaze_right_x": rx, "gaze_right_y": ry, "gaze_left_x": lx, "gaze_left_y": ly}


@pytest.mark.parametrize(
    ("steps", "expected"),
    [
        # (openness right, left, gaze in) -> gaze out
        ([(OPEN, OPEN, _gaze(0.1, 0.2, 0.3, 0.4))], _gaze(0.1, 0.2, 0.3, 0.4)),
        # blink: both hold the last shown gaze whatever the closed eyes' iris says
        (
            [(OPEN, OPEN, _gaze(0.1, 0.2, 0.3, 0.4)), (SHUT, SHUT, _gaze(-9, -9, -9, -9))],
            _gaze(0.1, 0.2, 0.3, 0.4),
        ),
        # wink (right eye shut): the right eye takes the open left eye's gaze
        (
            [(OPEN, OPEN, _gaze(0.1, 0.2, 0.3, 0.4)), (SHUT, OPEN, _gaze(-9, -9, 0.05, -0.06))],
            _gaze(0.05, -0.06, 0.05, -0.06),
        ),
        # wink (left eye shut)
        ([(OPEN, SHUT, _gaze(0.07, 0.01, -9, -9))], _gaze(0.07, 0.01, 0.07, 0.01)),
        # wink then blink: hold what was shown during the wink
        (
            [(SHUT, OPEN, _gaze(-9, -9, 0.05, 0.02)), (SHUT, SHUT, _gaze(-9, -9, -9, -9))],
            _gaze(0.05, 0.02, 0.05, 0.02),
        ),
        # eyes reopen: own gaze again
        (
            [(SHUT, SHUT, _gaze(-9, -9, -9, -9)), (OPEN, OPEN, _gaze(0.1, 0.0, 0.2, 0.0))],
            _gaze(0.1, 0.0, 0.2, 0.0),
        ),
        # one eye's iris missing (no gaze) counts like a closed eye
        ([(OPEN, OPEN, {"gaze_left_x": 0.3, "gaze_left_y": 0.1})], _gaze(0.3, 0.1, 0.3, 0.1)),
        # closed from the start: nothing to show yet
        ([(SHUT, SHUT, _gaze(-9, -9, -9, -9))], {}),
        ([(OPEN, OPEN, {})], {}),
    ],
    ids=[
        "open",
        "blink-holds",
        "wink-right-conjugate",
        "wink-left-conjugate",
        "wink-then-blink",
        "reopen",
        "one-iris-missing",
        "closed-from-start",
        "no-iris",
    ],
)
def test_gaze_hold_rule(steps, expected) -> None:
    hold = GazeHold()
    out: dict[str, float] = {}
    for right, left, gaze in steps:
        out = _step(hold, right, left, gaze)
    assert out == expected


@pytest.mark.parametrize(
    ("neutral", "openness", "closed"),
    [
        (0.30, 0.19, False),  # above 0.6 * 0.30 = 0.18
        (0.30, 0.17, True),
        (0.20, 0.14, True),  # the absolute floor (0.15) applies
        (0.20, 0.16, False),
        (None, CLOSED_BELOW - 0.01, True),  # no neutral: the floor alone
        (math.nan, CLOSED_BELOW + 0.01, False),
    ],
    ids=["open-0.3", "shut-0.3", "floor-shut", "floor-open", "no-neutral", "nan-neutral"],
)
def test_closed_threshold(neutral, openness, closed) -> None:
    hold = GazeHold()
    assert hold.eye_open("right", openness, neutral) is (not closed)


def test_hysteresis_keeps_a_closing_eye_closed_near_the_threshold() -> None:
    hold = GazeHold()  # neutral 0.3: threshold 0.18, reopens above 0.198
    sequence = [0.3, 0.17, 0.19, 0.185, 0.197, 0.2, 0.19]
    assert [hold.eye_open("left", o, 0.3) for o in sequence] == [
        True,
        False,
        False,
        False,
        False,
        True,
        True,
    ]


def test_unknown_openness_counts_as_open() -> None:
    hold = GazeHold()
    hold.eye_open("right", 0.01, 0.3)
    assert hold.eye_open("right", None, 0.3)
    assert hold.eye_open("right", math.nan, 0.3)


def test_iris_depth_without_a_normal_is_nan() -> None:
    """Corners on one point have no plane to read depth in: NaN, never a ZeroDivisionError."""
    corner = np.array([[1.0, 2.0, 3.0]])
    depth = iris_depth(
        corner,
        corner,
        np.array([[1.0, 2.0, 2.0]]),
        np.array([0.0, -1.0, 0.0]),
        np.array([0.0, 0.0, -1.0]),
        np.array([[1.5, 2.0]]),
    )
    assert depth.shape == (1,) and math.isnan(depth[0])


def test_3d_gaze_of_an_eye_without_corners_is_left_out() -> None:
    """An eye whose corners meet has no frame: its gaze is left out (as NaN was before), the
    other eye's is read, nothing raises."""
    mesh = MESH.copy()
    mesh[133] = mesh[33]  # the right eye's inner corner on its outer one
    frame = own_frame(MESH)
    gaze = gaze_features_3d(IRIS, mesh, frame)
    assert set(gaze) == {"gaze_left_x", "gaze_left_y"}
    assert gaze == {k: v for k, v in gaze_features_3d(IRIS, MESH, frame).items() if "left" in k}


@pytest.mark.parametrize(
    "axis", [(0.0, 0.0, 0.0), (0.0, 2.0, 0.0), (0.0, -1e-200, 0.0)], ids=["none", "up", "tiny"]
)
def test_eye_frame_without_a_width_or_an_up_gives_no_gaze(axis) -> None:
    """No width, or an eye axis along the face's up (no vertical left): NaN, no exception."""
    x, y = _eye_frame_gaze(*axis, 0.1, 0.2, 0.3)
    assert math.isnan(x) and math.isnan(y)
