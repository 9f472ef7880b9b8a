"""services.features.pose: the mesh's face frame, similarity fit, head pose and its signs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from synthetic_face import IRIS, MESH, ibug_of, rotation_from_euler, to_face_frame, transform

from facesynth.services.features import pose
from facesynth.services.features.frame import FeatureError
from facesynth.services.features.pose import (
    STABLE_VERTICES,
    FitTarget,
    MeshReference,
    PoseError,
    camera_pose,
    euler_degrees,
    face_axes,
    median_mesh,
    roll_2d,
    similarity_fit,
    svd3,
)

ANGLES = [
    (0.0, 0.0, 0.0),
    (20.0, 0.0, 0.0),
    (-35.0, 0.0, 0.0),
    (0.0, 15.0, 0.0),
    (0.0, -25.0, 0.0),
    (0.0, 0.0, 12.0),
    (0.0, 0.0, -30.0),
    (25.0, -10.0, 8.0),
    (-15.0, 20.0, -20.0),
]
ANGLE_IDS = [f"y{y:g}p{p:g}r{r:g}" for y, p, r in ANGLES]


@pytest.mark.parametrize(("yaw", "pitch", "roll"), ANGLES, ids=ANGLE_IDS)
def test_euler_round_trip(yaw: float, pitch: float, roll: float) -> None:
    rotation = rotation_from_euler(yaw, pitch, roll)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0)
    np.testing.assert_allclose(euler_degrees(rotation), (yaw, pitch, roll), atol=1e-9)


@pytest.mark.parametrize(
    ("angles", "vertex", "axis", "direction"),
    [
        # yaw toward the performer's left: the nose tip goes to the image's right
        ((15.0, 0.0, 0.0), 1, 0, +1),
        ((-15.0, 0.0, 0.0), 1, 0, -1),
        # pitch, chin up: the nose tip goes up in the image (smaller y), the chin toward the camera
        ((0.0, 15.0, 0.0), 1, 1, -1),
        ((0.0, 15.0, 0.0), 152, 2, -1),
        ((0.0, -15.0, 0.0), 1, 1, +1),
        # roll toward the left shoulder: the performer's left eye (image right) goes down
        ((0.0, 0.0, 15.0), 263, 1, +1),
        ((0.0, 0.0, 15.0), 33, 1, -1),
        ((0.0, 0.0, -15.0), 263, 1, -1),
    ],
    ids=[
        "yaw+",
        "yaw-",
        "pitch+nose",
        "pitch+chin-z",
        "pitch-",
        "roll+left-eye",
        "roll+right-eye",
        "roll-",
    ],
)
def test_angle_signs_move_the_face_as_the_contract_says(angles, vertex, axis, direction) -> None:
    moved, _ = transform(MESH, IRIS, yaw=angles[0], pitch=angles[1], roll=angles[2])
    assert np.sign(moved[vertex, axis] - MESH[vertex, axis]) == direction
    reference = MeshReference(MESH)
    _, head = reference.align(moved)
    np.testing.assert_allclose(euler_degrees(head), angles, atol=1e-6)


@pytest.mark.parametrize(("yaw", "pitch", "roll"), ANGLES, ids=ANGLE_IDS)
@pytest.mark.parametrize(
    ("scale", "shift"),
    [(1.0, (0.0, 0.0, 0.0)), (0.6, (-80.0, 40.0, 12.0)), (1.7, (30.0, -20.0, -50.0))],
    ids=["same", "smaller-shifted", "larger-shifted"],
)
def test_align_recovers_rotation_and_undoes_it(yaw, pitch, roll, scale, shift) -> None:
    moved, _ = transform(MESH, IRIS, yaw=yaw, pitch=pitch, roll=roll, scale=scale, shift=shift)
    reference = MeshReference(MESH)
    aligned, head = reference.align(moved)
    np.testing.assert_allclose(euler_degrees(head), (yaw, pitch, roll), atol=1e-6)
    np.testing.assert_allclose(aligned, reference.canonical, atol=1e-9)


def test_face_frame_of_the_neutral() -> None:
    canonical = to_face_frame(MESH)
    np.testing.assert_allclose(canonical[33], [-0.5, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(canonical[263], [0.5, 0.0, 0.0], atol=1e-12)
    assert canonical[10, 1] > 0.5, "forehead up"
    assert canonical[152, 1] < -1.0, "chin down"
    assert canonical[1, 2] > 0.2, "nose tip toward the camera (+z)"
    assert canonical[70, 0] < 0 < canonical[300, 0], "performer's right brow at -x"
    _, axes, iod = face_axes(MESH)
    assert iod == pytest.approx(150.0)
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(axes) == pytest.approx(1.0)
    np.testing.assert_allclose(camera_pose(MESH), (0.0, 0.0, 0.0), atol=1e-9)


@pytest.mark.parametrize(("yaw", "pitch", "roll"), ANGLES[1:], ids=ANGLE_IDS[1:])
def test_camera_pose_without_a_neutral(yaw, pitch, roll) -> None:
    moved, _ = transform(MESH, IRIS, yaw=yaw, pitch=pitch, roll=roll)
    np.testing.assert_allclose(camera_pose(moved), (yaw, pitch, roll), atol=1e-6)


@pytest.mark.parametrize("roll", [-30.0, -5.0, 0.0, 7.5, 25.0])
def test_2d_roll_agrees_with_the_mesh_roll(roll: float) -> None:
    moved, _ = transform(MESH, IRIS, roll=roll)
    ibug = ibug_of(moved)
    assert roll_2d(ibug[36], ibug[45]) == pytest.approx(roll, abs=1e-6)


@pytest.mark.parametrize(
    ("scale", "angles", "shift"),
    [
        (1.0, (0, 0, 0), (0, 0, 0)),
        (2.5, (40, -10, 5), (3, 4, 5)),
        (0.01, (-90, 30, 170), (-1, 0, 9)),
    ],
    ids=["identity", "general", "tiny-large-angles"],
)
def test_similarity_fit(scale, angles, shift) -> None:
    rng = np.random.default_rng(3)
    source = rng.normal(size=(30, 3))
    rotation = rotation_from_euler(*angles)
    target = scale * source @ rotation.T + np.asarray(shift, dtype=float)
    s, r, t = similarity_fit(source, target)
    assert s == pytest.approx(scale)
    np.testing.assert_allclose(r, rotation, atol=1e-9)
    np.testing.assert_allclose(t, shift, atol=1e-9)


def test_svd3_is_numpys_svd_bit_for_bit() -> None:
    """The fits' SVD calls numpy's own LAPACK routine: the same three arrays, bit for bit, for
    general, reflecting, rank-deficient and zero matrices."""
    assert pose._SVD_F is not None  # numpy 1.26 and 2.x have the call (else: np.linalg.svd)
    rng = np.random.default_rng(5)
    matrices = [rng.normal(size=(3, 3)) for _ in range(200)]
    matrices += [np.diag([2.0, 1.0, -1.0]), np.outer([1.0, 2, 3], [4.0, 5, 6]), np.zeros((3, 3))]
    for matrix in matrices:
        for ours, numpys in zip(svd3(matrix), np.linalg.svd(matrix), strict=True):
            assert ours.tobytes() == numpys.tobytes()


def test_a_centred_target_gives_the_same_fit() -> None:
    """A target centred once (``FitTarget``, as a neutral's are) fits as the plain array does."""
    rng = np.random.default_rng(6)
    source, target = rng.normal(size=(25, 3)), rng.normal(size=(25, 3)) * 40.0 + 300.0
    plain, centred = similarity_fit(source, target), similarity_fit(source, FitTarget(target))
    assert plain[0] == centred[0]
    assert plain[1].tobytes() == centred[1].tobytes()
    assert plain[2].tobytes() == centred[2].tobytes()


@pytest.mark.parametrize(("yaw", "pitch", "roll"), ANGLES[:5], ids=ANGLE_IDS[:5])
def test_both_fits_at_once_are_each_fit_alone(yaw: float, pitch: float, roll: float) -> None:
    """``MeshReference.fits``: one centring, one SVD call for two targets, and still each fit
    bit for bit as computed alone."""
    reference = MeshReference(transform(MESH, IRIS, yaw=5.0, shift=(4.0, -2.0, 1.0))[0])
    mesh = transform(MESH, IRIS, yaw=yaw, pitch=pitch, roll=roll, scale=1.2)[0]
    frontal, face = reference.fits(mesh)
    alone = (
        similarity_fit(mesh[np.asarray(STABLE_VERTICES)], reference.mesh[list(STABLE_VERTICES)]),
        reference.fit(mesh),
    )
    for both, single in zip((frontal, face), alone, strict=True):
        assert both[0] == single[0]
        assert both[1].tobytes() == single[1].tobytes()
        assert both[2].tobytes() == single[2].tobytes()
    with pytest.raises(PoseError):
        reference.fits(np.zeros_like(MESH))


def test_similarity_fit_never_reflects() -> None:
    rng = np.random.default_rng(4)
    source = rng.normal(size=(20, 3))
    mirrored = source * np.array([-1.0, 1.0, 1.0])
    _, rotation, _ = similarity_fit(source, mirrored)
    assert np.linalg.det(rotation) == pytest.approx(1.0)


def test_median_mesh_aligns_before_taking_the_median() -> None:
    meshes = [
        transform(MESH, IRIS, yaw=y, pitch=p, roll=r, scale=s, shift=(d, -d, 0.0))[0]
        for y, p, r, s, d in [(0, 0, 0, 1, 0), (10, -5, 3, 1.2, 20), (-8, 4, -6, 0.9, -15)]
    ]
    np.testing.assert_allclose(median_mesh(meshes), MESH, atol=1e-9)
    with pytest.raises(PoseError):
        median_mesh([])


def _collapsed_eyes() -> np.ndarray:
    mesh = MESH.copy()
    mesh[263] = mesh[33]
    return mesh


def _flat_nose() -> np.ndarray:
    mesh = MESH.copy()
    mesh[168] = mesh[2] + (mesh[263] - mesh[33])  # nose line along the eye line
    return mesh


def _collapsed_stable() -> np.ndarray:
    mesh = MESH.copy()
    mesh[list(STABLE_VERTICES)] = mesh[1]
    return mesh


@pytest.mark.parametrize(
    ("mesh", "message"),
    [
        (_collapsed_eyes(), "eye corners are 0 px apart"),
        (_flat_nose(), "nose is degenerate"),
        (np.full((468, 3), math.nan), "eye corners are nan px apart"),
    ],
    ids=["eyes", "nose", "nan"],
)
def test_degenerate_meshes_have_no_face_frame(mesh: np.ndarray, message: str) -> None:
    with pytest.raises(PoseError, match=message):
        face_axes(mesh)
    assert issubclass(PoseError, FeatureError)


def test_collapsed_stable_vertices_have_no_pose() -> None:
    with pytest.raises(PoseError, match="collapsed"):
        MeshReference(MESH).align(_collapsed_stable())


@pytest.mark.parametrize(
    "mesh",
    [np.zeros((468, 2)), np.zeros((467, 3)), np.full((468, 3), math.inf)],
    ids=["2d", "467", "inf"],
)
def test_mesh_reference_needs_a_finite_3d_mesh(mesh: np.ndarray) -> None:
    with pytest.raises(PoseError, match=r"neutral mesh needs \(468, 3\) finite values"):
        MeshReference(mesh)
