"""services.control.drivers.virtual.geometry: the face as a pure function of the controls."""

from __future__ import annotations

import math
import random

import msgspec
import pytest

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.drivers.virtual.geometry import (
    FACE_CONTROLS,
    FACE_HEIGHT,
    FACE_WIDTH,
    NEUTRAL,
    Shape,
    draws_face,
    face_geometry,
)


def shapes(**controls: float) -> dict[str, Shape]:
    return {shape.name: shape for shape in face_geometry(controls)}


def centre(shape: Shape) -> tuple[float, float]:
    xs = [p[0] for p in shape.points]
    ys = [p[1] for p in shape.points]
    return sum(xs) / len(xs), sum(ys) / len(ys)


def lowest(shape: Shape) -> float:
    return max(p[1] for p in shape.points)


def test_neutral_is_the_face_without_controls() -> None:
    assert face_geometry({}) == face_geometry(NEUTRAL)
    names = [s.name for s in face_geometry({})]
    assert names[0] == "head"  # drawn first, everything else on top
    for side in ("right", "left"):  # lids are drawn over the iris and pupil they cover
        assert names.index(f"upper_lid_{side}") > names.index(f"pupil_{side}")


# control, value, shape, how its centre moves: (axis 0 = x / 1 = y, sign)
MOVES = [
    ("brow_right", 1000, "brow_right", 1, -1),  # raised: up (y down)
    ("brow_left", 0, "brow_left", 1, +1),  # frown: down
    ("gaze_right_x", 1000, "iris_right", 0, +1),  # toward the performer's left: viewer's right
    ("gaze_left_x", 0, "iris_left", 0, -1),
    ("gaze_right_y", 1000, "iris_right", 1, -1),  # up
    ("gaze_left_y", 0, "pupil_left", 1, +1),
    ("cheek_left", 1000, "cheek_left", 1, -1),  # raised
    ("lip_corner_right", 1000, "upper_lip", 1, -1),  # smile lifts the corners
    ("lip_corner_left", 0, "upper_lip", 1, +1),
    ("lower_lip", 1000, "lower_lip", 1, +1),
    ("jaw", 1000, "lower_lip", 1, +1),
    ("head_yaw", 1000, "nose", 0, +1),  # turned toward the performer's left
    ("head_pitch", 1000, "nose", 1, -1),  # chin up
]


@pytest.mark.parametrize(("control", "value", "name", "axis", "sign"), MOVES)
def test_each_control_moves_its_part(
    control: str, value: float, name: str, axis: int, sign: int
) -> None:
    before = centre(shapes()[name])[axis]
    after = centre(shapes(**{control: value})[name])[axis]
    assert (after - before) * sign > 2.0


def test_the_right_eye_is_on_the_viewers_left() -> None:
    face = shapes()
    assert centre(face["eye_right"])[0] < FACE_WIDTH / 2 < centre(face["eye_left"])[0]


def test_a_closed_lid_covers_the_eye_and_a_wide_one_shows_more() -> None:
    def opening(lid: float) -> float:  # the lash line's height above the eye corners
        lash = shapes(lid_left=lid)["lash_left"]
        corners = (lash.points[0][1] + lash.points[-1][1]) / 2
        return corners - min(p[1] for p in lash.points)

    assert opening(0) == pytest.approx(0.0, abs=0.2)
    assert 0 < opening(250) < opening(500) < opening(1000)


def test_the_jaw_drops_the_chin_and_opens_the_mouth() -> None:
    closed, open_ = shapes(), shapes(jaw=1000)
    assert lowest(open_["head"]) > lowest(closed["head"]) + 30
    assert lowest(open_["mouth"]) > lowest(closed["mouth"]) + 30


def test_raised_cheeks_blush() -> None:
    assert shapes(cheek_right=1000)["cheek_right"].fill != shapes()["cheek_right"].fill


def test_roll_tilts_the_whole_face_clockwise_on_screen() -> None:
    upright, tilted = shapes(), shapes(head_roll=1000)
    # Toward the performer's left shoulder: the top of the head goes to the viewer's right.
    top = min(upright["head"].points, key=lambda p: p[1])
    top_tilted = tilted["head"].points[upright["head"].points.index(top)]
    assert top_tilted[0] > top[0] + 20
    left, right = centre(tilted["eye_right"]), centre(tilted["eye_left"])
    assert math.degrees(math.atan2(right[1] - left[1], right[0] - left[0])) == pytest.approx(
        25, abs=1
    )


@pytest.mark.parametrize(
    "bad",
    [{"jaw": math.nan}, {"jaw": math.inf}, {"jaw": -math.inf}, {"jaw": "open"}, {"jaw": None}],
)
def test_values_that_are_not_numbers_count_as_neutral(bad: dict[str, object]) -> None:
    assert face_geometry(bad) == face_geometry({})  # type: ignore[arg-type]


def test_values_are_clamped_and_unknown_names_ignored() -> None:
    assert face_geometry({"jaw": 5000}) == face_geometry({"jaw": 1000})
    assert face_geometry({"brow_left": -20}) == face_geometry({"brow_left": 0})
    assert face_geometry({"tail": 1000}) == face_geometry({})


def test_random_controls_stay_finite_and_in_a_bounded_box() -> None:
    rng = random.Random(7)
    for _ in range(300):
        controls = {name: rng.uniform(-200, 1200) for name in NEUTRAL}
        for shape in face_geometry(controls):
            assert shape.kind in ("polygon", "polyline", "circle")
            assert shape.points and all(len(p) == 2 for p in shape.points)
            for x, y in shape.points:
                assert math.isfinite(x) and math.isfinite(y)
                assert -0.25 * FACE_WIDTH < x < 1.25 * FACE_WIDTH
                assert -0.25 * FACE_HEIGHT < y < 1.25 * FACE_HEIGHT
            for colour in (shape.fill, shape.stroke):
                assert colour is None or (len(colour) == 7 and colour[0] == "#")


def test_shapes_are_json_for_the_page() -> None:
    data = msgspec.json.decode(msgspec.json.encode(face_geometry({"jaw": 700})))
    assert data[0]["name"] == "head" and data[0]["kind"] == "polygon"
    assert msgspec.convert(data, list[Shape]) == face_geometry({"jaw": 700})


def test_which_profiles_are_drawn_as_the_face() -> None:
    assert draws_face(s.name for s in load_profile("virtual").servos)
    assert not draws_face(s.name for s in load_profile("paper16").servos)
    assert not draws_face(sorted(FACE_CONTROLS)[1:])  # one missing: bars only
