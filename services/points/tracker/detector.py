"""BlazeFace short-range face detector (MediaPipe ``face_detection_short_range.tflite``).

The whole frame is letterboxed (aspect ratio kept, black padding) into a 128x128 input scaled
to [-1, 1]. The model scores 896 SSD anchors — a 16x16 grid (stride 8) with 2 anchors per cell,
then an 8x8 grid (stride 16) with 6 anchors per cell, anchor centres at cell centres in [0, 1] —
and regresses, per anchor, the box centre offset, box size and 6 keypoints (subject's right eye,
left eye, nose tip, mouth centre, right ear tragion, left ear tragion) in input pixels.
Decoded detections go through (weighted) non-maximum suppression and are mapped back to frame
pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .model_input import fill_input, frame_to_rgba
from .runtimes import Model

__all__ = [
    "NUM_ANCHORS",
    "Detection",
    "FaceDetector",
    "box_iou",
    "decode_detections",
    "generate_anchors",
    "non_max_suppression",
]

NUM_ANCHORS = 896
NUM_KEYPOINTS = 6
_INPUT = 128
# (grid size, anchors per cell): MediaPipe's SsdAnchorsCalculator for the short-range model
# (strides 8, 16, 16, 16; the three stride-16 layers share one 8x8 grid).
_GRIDS: tuple[tuple[int, int], ...] = ((16, 2), (8, 6))


@dataclass(frozen=True, slots=True)
class Detection:
    """One detected face in frame pixels.

    Attributes:
        score: sigmoid confidence in [0, 1].
        box: (x0, y0, x1, y1).
        keypoints: (6, 2) float64: right eye, left eye (the subject's), nose tip, mouth centre,
            right ear tragion, left ear tragion.
    """

    score: float
    box: tuple[float, float, float, float]
    keypoints: np.ndarray

    @property
    def area(self) -> float:
        """Box area in square pixels."""
        x0, y0, x1, y1 = self.box
        return max(0.0, x1 - x0) * max(0.0, y1 - y0)


def generate_anchors() -> np.ndarray:
    """Anchor centres (896, 2) float32 in normalised [0, 1] input coordinates, in model order
    (grid row, grid column, anchor within the cell)."""
    parts = []
    for n, per_cell in _GRIDS:
        c = (np.arange(n, dtype=np.float32) + 0.5) / n
        yy, xx = np.meshgrid(c, c, indexing="ij")
        cells = np.stack([xx.ravel(), yy.ravel()], axis=1)
        parts.append(np.repeat(cells, per_cell, axis=0))
    anchors = np.concatenate(parts)
    assert anchors.shape == (NUM_ANCHORS, 2)
    return anchors


def decode_detections(
    raw_boxes: np.ndarray, raw_scores: np.ndarray, anchors: np.ndarray, input_size: int = _INPUT
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Decode raw model outputs.

    Args:
        raw_boxes: (896, 16) regressors in input pixels.
        raw_scores: (896,) logits.
        anchors: (896, 2) anchor centres from :func:`generate_anchors`.
        input_size: model input side in pixels.

    Returns:
        boxes (896, 4) as normalised (x0, y0, x1, y1); keypoints (896, 6, 2) normalised;
        scores (896,) = sigmoid(clip(logit, -100, 100)).
    """
    r = np.asarray(raw_boxes, dtype=np.float64).reshape(-1, 4 + 2 * NUM_KEYPOINTS) / input_size
    a = np.asarray(anchors, dtype=np.float64)
    centre = r[:, 0:2] + a
    half = r[:, 2:4] / 2.0
    boxes = np.concatenate([centre - half, centre + half], axis=1)
    keypoints = r[:, 4:].reshape(-1, NUM_KEYPOINTS, 2) + a[:, None, :]
    logits = np.clip(np.asarray(raw_scores, dtype=np.float64).ravel(), -100.0, 100.0)
    scores = 1.0 / (1.0 + np.exp(-logits))
    return boxes, keypoints, scores


def box_iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Intersection over union of one (x0, y0, x1, y1) box with each row of ``boxes`` (N, 4)."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    ix0 = np.maximum(box[0], b[:, 0])
    iy0 = np.maximum(box[1], b[:, 1])
    ix1 = np.minimum(box[2], b[:, 2])
    iy1 = np.minimum(box[3], b[:, 3])
    inter = np.clip(ix1 - ix0, 0.0, None) * np.clip(iy1 - iy0, 0.0, None)
    area_a = max(0.0, float(box[2] - box[0])) * max(0.0, float(box[3] - box[1]))
    area_b = np.clip(b[:, 2] - b[:, 0], 0.0, None) * np.clip(b[:, 3] - b[:, 1], 0.0, None)
    union = area_a + area_b - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def non_max_suppression(
    boxes: np.ndarray,
    keypoints: np.ndarray,
    scores: np.ndarray,
    iou_threshold: float = 0.3,
    weighted: bool = True,
) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Greedy NMS, highest score first.

    With ``weighted`` (MediaPipe's WeightedNonMaxSuppression) each kept detection's box and
    keypoints are the score-weighted mean of every candidate overlapping it by more than
    ``iou_threshold``; its score is the top candidate's. Otherwise overlapping candidates are
    simply dropped.

    Returns a list of (box (4,), keypoints (K, 2), score), best first.
    """
    order = np.argsort(-np.asarray(scores), kind="stable")
    remaining = order
    out: list[tuple[np.ndarray, np.ndarray, float]] = []
    while remaining.size:
        top = remaining[0]
        ious = box_iou(boxes[top], boxes[remaining])
        overlap = ious > iou_threshold
        overlap[0] = True
        members = remaining[overlap]
        if weighted and members.size > 1:
            w = scores[members] / scores[members].sum()
            box = (boxes[members] * w[:, None]).sum(axis=0)
            kps = (keypoints[members] * w[:, None, None]).sum(axis=0)
        else:
            box, kps = boxes[top].copy(), keypoints[top].copy()
        out.append((box, kps, float(scores[top])))
        remaining = remaining[~overlap]
    return out


class FaceDetector:
    """Letterbox + BlazeFace + decode + NMS, returning detections in frame pixels."""

    def __init__(
        self,
        model: Model,
        min_score: float = 0.5,
        iou_threshold: float = 0.3,
        weighted: bool = True,
    ) -> None:
        """Args:
        model: the loaded detector (:data:`~services.points.tracker.model_files.DETECTOR`).
        min_score: drop anchors scoring below this before NMS.
        iou_threshold: NMS overlap threshold.
        weighted: weighted (MediaPipe) or plain NMS.
        """
        if model.input_size != _INPUT:
            raise ValueError(f"detector input must be {_INPUT}, got {model.input_size}")
        self.model = model
        self.min_score = min_score
        self.iou_threshold = iou_threshold
        self.weighted = weighted
        self.anchors = generate_anchors()
        self._buf = np.zeros((_INPUT, _INPUT, 4), np.uint8)
        self._rgb = np.zeros((_INPUT, _INPUT, 3), np.uint8)
        self._shape: tuple[int, int] | None = None
        self._m = np.zeros((2, 3))
        self._scale = 1.0
        self._pad = (0.0, 0.0)

    def _letterbox(self, h: int, w: int) -> None:
        if self._shape == (h, w):
            return
        s = _INPUT / max(h, w)
        ox, oy = (_INPUT - w * s) / 2.0, (_INPUT - h * s) / 2.0
        self._m = np.array([[s, 0.0, ox], [0.0, s, oy]])
        self._scale, self._pad, self._shape = s, (ox, oy), (h, w)

    def to_frame(self, normalised: np.ndarray) -> np.ndarray:
        """Map normalised input coordinates (..., 2) of the last frame back to frame pixels."""
        p = np.asarray(normalised, dtype=np.float64) * _INPUT
        return (p - np.array(self._pad)) / self._scale

    def detect(self, image_bgr: np.ndarray) -> list[Detection]:
        """Detect faces in a uint8 BGR frame; best score first."""
        return self.detect_rgba(frame_to_rgba(image_bgr))

    def detect_rgba(self, frame_rgba: np.ndarray) -> list[Detection]:
        """Detect faces in a uint8 RGBA frame (see :func:`frame_to_rgba`); best score first."""
        h, w = frame_rgba.shape[:2]
        self._letterbox(h, w)
        cv2.warpAffine(
            frame_rgba,
            self._m,
            (_INPUT, _INPUT),
            dst=self._buf,
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(0, 0, 0, 0),
        )
        fill_input(self.model.input_view()[0], self._buf, 1.0 / 127.5, -1.0, self._rgb)
        out = self.model.run()
        boxes, kps, scores = decode_detections(
            out["regressors"][0], out["classificators"][0], self.anchors
        )
        keep = scores >= self.min_score
        if not keep.any():
            return []
        kept = non_max_suppression(
            boxes[keep], kps[keep], scores[keep], self.iou_threshold, self.weighted
        )
        dets = []
        for box, k, score in kept:
            b = self.to_frame(box.reshape(2, 2)).ravel()
            dets.append(
                Detection(
                    score,
                    (float(b[0]), float(b[1]), float(b[2]), float(b[3])),
                    self.to_frame(k),
                )
            )
        return dets
