"""Crop maths on synthetic inputs."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from facesynth.services.points.tracker.crops import (
    CropRect,
    compose_affine,
    crop_affine,
    flip_horizontal_affine,
    invert_affine,
    rect_from_box,
    rect_from_points,
    rotation_angle,
    transform_points,
)

RNG = np.random.default_rng(7)


@pytest.mark.parametrize(
    "rect, size",
    [
        (CropRect(320.0, 180.0, 0.0, 200.0), 192),
        (CropRect(100.5, 40.25, 0.3, 57.0), 64),
        (CropRect(-20.0, 500.0, -2.5, 1000.0), 128),
        (CropRect(0.0, 0.0, math.pi, 1.0), 192),
    ],
)
def test_round_trip(rect: CropRect, size: int) -> None:
    m = crop_affine(rect, size)
    inv = invert_affine(m)
    pts = RNG.uniform(-500, 500, (50, 2))
    back = transform_points(inv, transform_points(m, pts))
    np.testing.assert_allclose(back, pts, atol=1e-9)
    # the centre lands in the middle of the crop, the corners on the crop corners
    np.testing.assert_allclose(transform_points(m, [[rect.cx, rect.cy]]), [[size / 2, size / 2]])
    np.testing.assert_allclose(
        transform_points(m, rect.corners()),
        [[0, 0], [size, 0], [size, size], [0, size]],
        atol=1e-9,
    )


@pytest.mark.parametrize(
    "angle_deg, frame_dir, crop_dir",
    [
        # a frame vector along the rect's angle becomes +x in the crop
        (0, (1, 0), (1, 0)),
        (90, (0, 1), (1, 0)),  # eye line pointing down the image
        (90, (1, 0), (0, -1)),
        (-90, (1, 0), (0, 1)),
        (180, (1, 0), (-1, 0)),
        (30, (math.cos(math.radians(30)), math.sin(math.radians(30))), (1, 0)),
        (45, (0, 1), (math.sqrt(0.5), math.sqrt(0.5))),
    ],
)
def test_rotation_by_known_angles(
    angle_deg: float, frame_dir: tuple[float, float], crop_dir: tuple[float, float]
) -> None:
    rect = CropRect(50.0, 60.0, math.radians(angle_deg), 100.0)
    m = crop_affine(rect, 100)  # scale 1
    p0 = transform_points(m, [[50.0, 60.0]])[0]
    p1 = transform_points(m, [[50.0 + frame_dir[0] * 10, 60.0 + frame_dir[1] * 10]])[0]
    np.testing.assert_allclose((p1 - p0) / 10, crop_dir, atol=1e-12)


@pytest.mark.parametrize("side, size", [(100.0, 100), (384.0, 192), (32.0, 64), (7.5, 128)])
def test_scale(side: float, size: int) -> None:
    m = crop_affine(CropRect(10.0, 20.0, 0.7, side), size)
    # lengths scale by size / side whatever the rotation
    a, b = transform_points(m, [[0.0, 0.0], [3.0, 4.0]])
    assert np.linalg.norm(b - a) == pytest.approx(5.0 * size / side)
    assert abs(np.linalg.det(m[:, :2])) == pytest.approx((size / side) ** 2)


@pytest.mark.parametrize("bad_side", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_side_rejected(bad_side: float) -> None:
    with pytest.raises(ValueError):
        crop_affine(CropRect(0, 0, 0, bad_side), 64)


def test_invert_singular() -> None:
    with pytest.raises(ValueError):
        invert_affine(np.array([[1.0, 2.0, 0.0], [2.0, 4.0, 0.0]]))


def test_flip_and_compose() -> None:
    m = crop_affine(CropRect(30.0, 40.0, 0.2, 20.0), 64)
    f = compose_affine(flip_horizontal_affine(64), m)
    p = RNG.uniform(0, 100, (10, 2))
    q, qf = transform_points(m, p), transform_points(f, p)
    np.testing.assert_allclose(qf[:, 0], 64 - q[:, 0])
    np.testing.assert_allclose(qf[:, 1], q[:, 1])
    np.testing.assert_allclose(transform_points(invert_affine(f), qf), p, atol=1e-9)


def test_rotation_angle_and_rect_helpers() -> None:
    assert rotation_angle(np.array([0, 0]), np.array([1, 1])) == pytest.approx(math.pi / 4)
    r = rect_from_box(10, 20, 50, 30, 0.1, 1.5)
    assert (r.cx, r.cy, r.angle, r.side) == pytest.approx((30, 25, 0.1, 60))
    pts = np.array([[0.0, 0.0], [10.0, 2.0], [4.0, 8.0]])
    r = rect_from_points(pts, 0, 1, 2.0)
    assert (r.cx, r.cy, r.side) == pytest.approx((5.0, 4.0, 20.0))
    assert r.angle == pytest.approx(math.atan2(2, 10))
    x, y, w, h = CropRect(0, 0, math.pi / 4, math.sqrt(2)).bbox()
    assert (x, y, w, h) == pytest.approx((-1, -1, 2, 2))


@pytest.mark.parametrize("angle_deg", [0, 17, -40, 90])
def test_warp_affine_places_a_dot_where_predicted(angle_deg: float) -> None:
    """The affine is what cv2.warpAffine samples with: a bright dot lands where predicted."""
    frame = np.zeros((360, 640), np.uint8)
    dot = (400.0, 150.0)
    cv2.circle(frame, (int(dot[0]), int(dot[1])), 3, 255, -1)
    rect = CropRect(380.0, 170.0, math.radians(angle_deg), 120.0)
    m = crop_affine(rect, 120)
    crop = cv2.warpAffine(frame, m, (120, 120), flags=cv2.INTER_LINEAR)
    ys, xs = np.nonzero(crop > 128)
    found = np.array([xs.mean(), ys.mean()])
    np.testing.assert_allclose(found, transform_points(m, [dot])[0], atol=0.6)
