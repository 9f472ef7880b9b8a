"""The paper's 68 points with the whole head rotation taken out against the neutral mesh
(services.features.frontal): yaw, pitch and roll, and the neutral's eye corners as the frame."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_face import IRIS, MESH, ibug_of, move, points_message, transform

from facesynth.runtime.ibug_mesh import mesh_to_ibug68
from facesynth.services.features.core import FeatureProcessor, normalise, nose_distances
from facesynth.services.features.frontal import frontalized, paper_frame
from facesynth.services.features.pose import MeshReference

REFERENCE = MeshReference(MESH)
NEUTRAL = nose_distances(normalise(ibug_of(MESH)))
#: The brows' points (17-26).
BROWS = slice(17, 27)
#: Mesh vertices of the outer eye corners and the skin beside them (a laugh pushes them).
OUTER_EYE = (33, 130, 263, 359)


def _posed(yaw: float = 0.0, pitch: float = 0.0, roll: float = 0.0) -> np.ndarray:
    mesh, _ = transform(MESH, IRIS, yaw=yaw, pitch=pitch, roll=roll, scale=0.8, shift=(30, -9, 4))
    return mesh


def test_at_the_neutral_pose_the_points_are_the_image_points() -> None:
    np.testing.assert_allclose(
        frontalized(ibug_of(MESH), MESH, REFERENCE), ibug_of(MESH), atol=1e-9
    )


@pytest.mark.parametrize(
    ("yaw", "pitch", "roll"),
    [(0.0, 14.0, 0.0), (0.0, -12.0, 0.0), (22.0, 12.0, 6.0), (-18.0, -8.0, -10.0)],
)
def test_a_turned_or_nodding_head_gives_the_neutral_distances(
    yaw: float, pitch: float, roll: float
) -> None:
    mesh = _posed(yaw, pitch, roll)
    plain = nose_distances(normalise(ibug_of(mesh)))
    yaw_only = nose_distances(paper_frame(ibug_of(mesh), mesh))
    assert np.abs(plain[BROWS] - NEUTRAL[BROWS]).max() > 0.01  # what the 2D frame reads
    if pitch:
        assert np.abs(yaw_only[BROWS] - NEUTRAL[BROWS]).max() > 0.01  # yaw alone: pitch stays
    frontal = nose_distances(paper_frame(ibug_of(mesh), mesh, REFERENCE))
    np.testing.assert_allclose(frontal, NEUTRAL, atol=1e-9)


def test_the_neutral_eye_corners_set_the_frame() -> None:
    """An expression that moves the outer eye corners (a laugh's cheeks push them out) leaves
    the brows' distances as they were: only the points' own corners would rescale them."""
    wide = move(MESH, OUTER_EYE[:2], dx=-0.03)
    wide = move(wide, OUTER_EYE[2:], dx=0.03)
    own = nose_distances(normalise(ibug_of(wide)))
    assert np.abs(own[BROWS] - NEUTRAL[BROWS]).min() > 0.03
    frontal = nose_distances(paper_frame(ibug_of(wide), wide, REFERENCE))
    # the fit's vertices include the outer eye corners: they move the fit a little, not the frame
    np.testing.assert_allclose(frontal[BROWS], NEUTRAL[BROWS], atol=4e-3)


def test_a_brow_raise_still_reads_on_a_turned_head() -> None:
    brows = (70, 63, 105, 66, 107, 336, 296, 334, 293, 300)  # the iBUG brow points' vertices
    raised = move(MESH, brows, dy=0.05)
    mesh, _ = transform(raised, IRIS, yaw=20.0, pitch=10.0, scale=0.8, shift=(30, -9, 4))
    frontal = nose_distances(paper_frame(ibug_of(mesh), mesh, REFERENCE))
    assert (frontal[BROWS] - NEUTRAL[BROWS]).min() > 0.02


def test_a_mesh_the_fit_cannot_use_leaves_the_2d_frame() -> None:
    ibug = ibug_of(_posed(yaw=20.0))
    collapsed = np.zeros_like(MESH)
    np.testing.assert_array_equal(paper_frame(ibug, collapsed, REFERENCE), normalise(ibug))
    np.testing.assert_array_equal(paper_frame(ibug, None, REFERENCE), normalise(ibug))


def test_the_neutral_frame_is_the_neutral_mesh_points() -> None:
    neutral = mesh_to_ibug68(MESH).astype(np.float64)
    np.testing.assert_allclose(
        paper_frame(ibug_of(MESH), MESH, REFERENCE), normalise(neutral), atol=1e-4
    )


def test_the_processor_reads_a_nodding_head_as_no_movement() -> None:
    """F frontalises against the neutral mesh it measured (its first half second here), and the
    neutral's own distances are read the same way."""
    processor = FeatureProcessor(neutral_seconds=0.5)
    for i in range(20):
        processor.process(points_message(seq=i, t_media_ns=i * 50_000_000))
    assert processor.reference is not None
    for j, (yaw, pitch) in enumerate(((0.0, 14.0), (-15.0, -10.0), (20.0, 8.0))):
        out = processor.process(points_message(_posed(yaw, pitch), seq=20 + j, t_media_ns=10**9))
        assert max(abs(d) for d in out.deltas) < 1e-6, (yaw, pitch)
        assert max(abs(d) for d in out.displacements) < 1e-6, (yaw, pitch)


def test_the_neutral_is_read_against_its_own_mesh_when_the_window_ends() -> None:
    """The first second's frames were read before the neutral mesh existed (the yaw alone
    undone); once it is known they are read again, in its pose: a first second turned and
    nodding, then a face held straight, reads no movement."""
    processor = FeatureProcessor(neutral_seconds=0.5)
    first = _posed(yaw=20.0, pitch=12.0)
    for i in range(11):
        processor.process(points_message(first, seq=i, t_media_ns=i * 50_000_000))
    assert processor.estimator.neutral is not None
    np.testing.assert_allclose(
        processor.estimator.neutral, nose_distances(normalise(ibug_of(first))), atol=1e-6
    )
    for j, (yaw, pitch) in enumerate(((0.0, 0.0), (-10.0, 5.0))):
        out = processor.process(points_message(_posed(yaw, pitch), seq=11 + j, t_media_ns=10**9))
        assert max(abs(d) for d in out.deltas) < 1e-6, (yaw, pitch)
