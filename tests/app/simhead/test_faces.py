"""The synthetic faces of ``facesynth bench fidelity``: the warp and the expressions it draws."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from facesynth.app.bench.fidelity import still_face
from facesynth.app.data import sample_video
from facesynth.app.simhead.faces import (
    EXPRESSIONS,
    IRIS_CENTRES,
    LIP_CORNERS,
    Face,
    expressions,
    render,
    warp,
)
from facesynth.services.points.tracker import FaceTracker


@pytest.fixture(scope="module")
def face() -> Face:
    return still_face(str(sample_video()))


@pytest.fixture(scope="module")
def tracker() -> FaceTracker:
    return FaceTracker(backend="litert", model="full")


def _track(tracker: FaceTracker, image: np.ndarray) -> np.ndarray:
    tracker.reset()
    for _ in range(4):
        result = tracker.process(image)
    assert result.face and result.mesh478 is not None
    return result.mesh478[:, :2]


@pytest.fixture(scope="module")
def tracked(face: Face, tracker: FaceTracker) -> Callable[[str | None], np.ndarray]:
    """The tracked landmarks of the still face (``None``) or of an expression by name, each
    drawn and tracked once per module: ``_track`` resets the tracker first, so an image always
    gives the same points. Read-only arrays: no test can change another's."""
    found: dict[str | None, np.ndarray] = {}

    def points(name: str | None) -> np.ndarray:
        if name not in found:
            if name is None:
                image = face.image
            else:
                image = render(face, next(e for e in expressions(face) if e.name == name))
            found[name] = _track(tracker, image).copy()
            found[name].flags.writeable = False
        return found[name]

    return points


def test_a_warp_moves_what_it_should_and_nothing_else() -> None:
    rng = np.random.default_rng(1)
    image = rng.integers(0, 255, (120, 160, 3), dtype=np.uint8)
    points = np.array([[80.0, 60.0], [30.0, 30.0]])
    still = warp(image, points, np.zeros((2, 2)), sigma=5.0)
    np.testing.assert_array_equal(still, image)
    moved = warp(image, points, np.array([[4.0, 0.0], [0.0, 0.0]]), sigma=5.0)
    # the pixel that was at the moving point is now 4 px to the right of it
    np.testing.assert_allclose(moved[60, 84].astype(float), image[60, 80].astype(float), atol=12)
    np.testing.assert_array_equal(moved[:, :40], image[:, :40])  # far away: untouched


def test_the_catalogue(face: Face) -> None:
    catalogue = expressions(face)
    assert tuple(e.name for e in catalogue) == EXPRESSIONS
    assert 100 < face.iod < 200
    for expression in catalogue:
        assert expression.move.shape == (478, 2)
        assert np.abs(expression.move[list(range(468, 478))]).max() == 0.0


def test_the_baseline_irises_are_centred(face: Face) -> None:
    for centre, (a, b) in zip(IRIS_CENTRES, ((33, 133), (362, 263)), strict=True):
        middle = (face.points[a, 0] + face.points[b, 0]) / 2
        assert abs(face.points[centre, 0] - middle) < 0.5


@pytest.mark.parametrize("name", ["smile", "brow_raise", "frown", "jaw_open"])
def test_the_tracker_sees_the_warped_motion(
    face: Face, tracked: Callable[[str | None], np.ndarray], name: str
) -> None:
    """The landmarks that an expression moves move the same way in the tracked image."""
    expression = next(e for e in expressions(face) if e.name == name)
    before, after = tracked(None), tracked(name)
    wanted = face.to_image(expression.move[:468, 0], expression.move[:468, 1])
    moving = np.linalg.norm(wanted, axis=1) > 0.5 * np.linalg.norm(wanted, axis=1).max()
    seen = (after - before)[:468][moving]
    along = (seen * wanted[moving]).sum(axis=1) / np.linalg.norm(wanted[moving], axis=1)
    assert np.median(along) > 0.3 * np.linalg.norm(wanted[moving], axis=1).mean(), name


@pytest.mark.parametrize(
    ("name", "direction"),
    [("look_left", (1, 0)), ("look_right", (-1, 0)), ("look_up", (0, -1)), ("look_down", (0, 1))],
)
def test_the_redrawn_irises_are_where_the_tracker_finds_them(
    tracked: Callable[[str | None], np.ndarray], name: str, direction: tuple[int, int]
) -> None:
    """(image directions: looking to the performer's left moves the irises to the image's
    right; up is toward smaller y)"""
    before, after = tracked(None), tracked(name)
    for centre in IRIS_CENTRES:
        shift = after[centre] - before[centre]
        assert float(np.dot(shift, direction)) > 1.0, (name, shift)


def test_a_smile_moves_the_lip_corners_out_and_up(
    tracked: Callable[[str | None], np.ndarray],
) -> None:
    before, after = tracked(None), tracked("smile")
    right, left = (after - before)[list(LIP_CORNERS)]
    assert right[0] < 0 < left[0]  # out: the right corner to the image's left
    assert right[1] < 0 and left[1] < 0  # up
