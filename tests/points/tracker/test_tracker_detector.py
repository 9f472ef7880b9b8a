"""BlazeFace anchors, decoding and NMS on synthetic inputs; the detector on real frames."""

from __future__ import annotations

import numpy as np
import pytest
from tracker_fixtures import TrackedVideo

from facesynth.services.points.tracker import FaceTracker
from facesynth.services.points.tracker.detector import (
    NUM_ANCHORS,
    box_iou,
    decode_detections,
    generate_anchors,
    non_max_suppression,
)


def test_anchor_layout() -> None:
    a = generate_anchors()
    assert a.shape == (NUM_ANCHORS, 2) == (896, 2)
    # 16x16 grid (stride 8), 2 anchors per cell, row-major, x fastest
    np.testing.assert_allclose(a[0], [0.5 / 16, 0.5 / 16])
    np.testing.assert_allclose(a[1], a[0])
    np.testing.assert_allclose(a[2], [1.5 / 16, 0.5 / 16])
    np.testing.assert_allclose(a[32], [0.5 / 16, 1.5 / 16])
    np.testing.assert_allclose(a[511], [15.5 / 16, 15.5 / 16])
    # then an 8x8 grid (stride 16), 6 anchors per cell
    np.testing.assert_allclose(a[512:518], np.tile([0.5 / 8, 0.5 / 8], (6, 1)))
    np.testing.assert_allclose(a[518], [1.5 / 8, 0.5 / 8])
    np.testing.assert_allclose(a[-1], [7.5 / 8, 7.5 / 8])
    assert len(np.unique(a[:512], axis=0)) == 256 and len(np.unique(a[512:], axis=0)) == 64


@pytest.mark.parametrize(
    "anchor, raw_xywh, expect_box",
    [
        # raw values in input pixels (128 = the whole input)
        (
            0,
            (0, 0, 32, 16),
            (0.5 / 16 - 0.125, 0.5 / 16 - 0.0625, 0.5 / 16 + 0.125, 0.5 / 16 + 0.0625),
        ),
        (700, (12.8, -6.4, 64, 64), None),
    ],
)
def test_decode_boxes(anchor: int, raw_xywh: tuple[float, ...], expect_box: tuple | None) -> None:
    anchors = generate_anchors()
    raw = np.zeros((896, 16), np.float32)
    raw[anchor, :4] = raw_xywh
    raw[anchor, 4:] = np.arange(12) - 6.0  # keypoint offsets in input pixels
    scores = np.full(896, -5.0, np.float32)
    boxes, kps, sc = decode_detections(raw, scores, anchors)
    cx, cy = anchors[anchor] + np.array(raw_xywh[:2]) / 128
    w, h = raw_xywh[2] / 128, raw_xywh[3] / 128
    np.testing.assert_allclose(boxes[anchor], [cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2])
    if expect_box is not None:
        np.testing.assert_allclose(boxes[anchor], expect_box)
    np.testing.assert_allclose(
        kps[anchor], anchors[anchor] + (np.arange(12) - 6.0).reshape(6, 2) / 128, atol=1e-7
    )
    # untouched anchors decode to zero-size boxes on the anchor centre
    other = (anchor + 1) % 896
    np.testing.assert_allclose(boxes[other], np.r_[anchors[other], anchors[other]], atol=1e-7)
    assert sc[0] == pytest.approx(1 / (1 + np.exp(5.0)))


@pytest.mark.parametrize(
    "logit, score", [(0.0, 0.5), (1e6, 1.0), (-1e6, 1 / (1 + np.exp(100.0))), (2.0, 0.8807970779)]
)
def test_score_sigmoid_with_clipping(logit: float, score: float) -> None:
    raw = np.zeros((896, 16))
    s = np.zeros(896)
    s[3] = logit
    _, _, sc = decode_detections(raw, s, generate_anchors())
    assert sc[3] == pytest.approx(score)
    assert np.isfinite(sc).all()


def test_box_iou() -> None:
    b = np.array([0.0, 0.0, 2.0, 2.0])
    others = np.array([[0, 0, 2, 2], [1, 0, 3, 2], [2, 2, 3, 3], [0, 0, 0, 0]], float)
    np.testing.assert_allclose(box_iou(b, others), [1.0, 2 / 6, 0.0, 0.0])


def _cluster() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    boxes = np.array(
        [
            [0.10, 0.10, 0.30, 0.30],
            [0.12, 0.10, 0.32, 0.30],  # overlaps the first (IoU ~0.82)
            [0.60, 0.60, 0.80, 0.80],  # a second face
            [0.61, 0.60, 0.81, 0.80],
        ]
    )
    kps = np.repeat(boxes[:, None, :2], 6, axis=1)
    scores = np.array([0.9, 0.6, 0.7, 0.7])
    return boxes, kps, scores


def test_plain_nms() -> None:
    boxes, kps, scores = _cluster()
    out = non_max_suppression(boxes, kps, scores, 0.3, weighted=False)
    assert len(out) == 2
    np.testing.assert_allclose(out[0][0], boxes[0])
    assert out[0][2] == 0.9
    np.testing.assert_allclose(out[1][0], boxes[2])  # stable order among equal scores


def test_weighted_nms() -> None:
    boxes, kps, scores = _cluster()
    out = non_max_suppression(boxes, kps, scores, 0.3, weighted=True)
    assert len(out) == 2
    expect = (boxes[0] * 0.9 + boxes[1] * 0.6) / 1.5
    np.testing.assert_allclose(out[0][0], expect)
    np.testing.assert_allclose(out[0][1][:, 0], expect[0])
    assert out[0][2] == 0.9  # the top score, not an average
    np.testing.assert_allclose(out[1][0], (boxes[2] + boxes[3]) / 2)


def test_nms_keeps_separate_faces_at_high_threshold() -> None:
    boxes, kps, scores = _cluster()
    assert len(non_max_suppression(boxes, kps, scores, 0.95, weighted=True)) == 4


def test_detector_on_real_frames(tracked_video: TrackedVideo, litert_tracker: FaceTracker) -> None:
    """One face per sample frame; box and eye keypoints agree with the tracked mesh."""
    tv = tracked_video
    for i, frame in tv.samples.items():
        dets = litert_tracker.detector.detect(frame)
        assert len(dets) == 1, f"frame {i}: {len(dets)} detections"
        d = dets[0]
        mesh = tv.results[i].mesh
        assert d.score > 0.8
        x0, y0, x1, y1 = d.box
        # the box may stick out of the frame a little, but its centre is inside
        assert 0 < (x0 + x1) / 2 < 640 and 0 < (y0 + y1) / 2 < 360
        assert 100 < x1 - x0 < 400 and 100 < y1 - y0 < 400
        # keypoint 0 is the subject's right eye (image left), 1 the left eye
        right_eye = mesh[[33, 133], :2].mean(axis=0)
        left_eye = mesh[[362, 263], :2].mean(axis=0)
        iod = np.linalg.norm(left_eye - right_eye)
        assert np.linalg.norm(d.keypoints[0] - right_eye) < 0.2 * iod, i
        assert np.linalg.norm(d.keypoints[1] - left_eye) < 0.2 * iod, i
        assert np.linalg.norm(d.keypoints[2] - mesh[1, :2]) < 0.3 * iod, i  # nose tip
