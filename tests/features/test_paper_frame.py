"""The paper's 68 nose-tip distances free of head yaw when the points come with a 3D mesh and no
neutral mesh is known yet (services.features.frontal.paper_frame, services.features.pose.unturned;
with a neutral mesh the whole rotation is taken out: test_frontal.py)."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_face import IRIS, MESH, ibug_of, points_message, transform

from facesynth.runtime.ibug_mesh import ibug68_depth, mapping_matrix
from facesynth.services.features.core import (
    FeatureProcessor,
    normalise,
    nose_distances,
    paper_frame,
)
from facesynth.services.features.pose import PoseError, unturned

FRONTAL = nose_distances(normalise(ibug_of(MESH)))
#: The brows' points (17-26): a head turn shortened one side's distances in 2D.
BROWS = slice(17, 27)


def _turned(yaw: float = 0.0, pitch: float = 0.0, roll: float = 0.0) -> np.ndarray:
    mesh, _ = transform(MESH, IRIS, yaw=yaw, pitch=pitch, roll=roll, scale=0.8, shift=(30, -9, 4))
    return mesh


def test_the_points_depth_is_the_mesh_depth_through_the_ibug_table() -> None:
    w = mapping_matrix().astype(np.float64)
    np.testing.assert_allclose(ibug68_depth(MESH), w @ MESH[:, 2], rtol=1e-6)
    with pytest.raises(ValueError, match="468, 3"):
        ibug68_depth(MESH[:, :2])


@pytest.mark.parametrize("yaw", [-30.0, -15.0, 10.0, 25.0])
def test_a_turned_head_gives_the_frontal_distances(yaw: float) -> None:
    mesh = _turned(yaw=yaw, roll=8.0)
    plain = nose_distances(normalise(ibug_of(mesh)))
    assert np.abs(plain[BROWS] - FRONTAL[BROWS]).max() > 0.01  # what the 2D frame reads
    np.testing.assert_allclose(nose_distances(paper_frame(ibug_of(mesh), mesh)), FRONTAL, atol=1e-9)


def test_only_the_yaw_is_undone() -> None:
    """Pitch is kept: undoing it with the tracker's depth over-corrects (see pose.unturned)."""
    pitched = nose_distances(paper_frame(ibug_of(_turned(pitch=12.0)), _turned(pitch=12.0)))
    both = _turned(yaw=20.0, pitch=12.0)
    turned = nose_distances(paper_frame(ibug_of(both), both))
    assert np.abs(pitched[BROWS] - FRONTAL[BROWS]).max() > 0.01
    np.testing.assert_allclose(turned, pitched, atol=0.002)


def test_without_a_mesh_the_frame_is_the_papers() -> None:
    ibug = ibug_of(_turned(yaw=20.0))
    np.testing.assert_array_equal(paper_frame(ibug), normalise(ibug))


def test_a_mesh_with_no_yaw_to_undo_keeps_the_image_points() -> None:
    edge_on = _turned(yaw=90.0)
    with pytest.raises(PoseError, match="does not face the camera"):
        unturned(np.column_stack([ibug_of(edge_on), ibug68_depth(edge_on)]), edge_on)
    collapsed = np.zeros_like(MESH)  # no face frame
    ibug = ibug_of(_turned(yaw=20.0))
    np.testing.assert_array_equal(paper_frame(ibug, collapsed), normalise(ibug))


def test_the_processor_reads_a_head_turn_as_no_brow_movement() -> None:
    processor = FeatureProcessor(neutral_seconds=0.5)
    for i in range(20):
        processor.process(points_message(seq=i, t_media_ns=i * 50_000_000))
    turned = _turned(yaw=20.0)
    out = processor.process(points_message(turned, seq=20, t_media_ns=10**9))
    assert max(abs(d) for d in out.deltas) < 1e-9
    flat = processor.process(points_message(turned, seq=21, t_media_ns=10**9, mesh_dims=2))
    assert max(abs(d) for d in flat.deltas[BROWS]) > 0.01  # a mesh without depth: the 2D frame
