"""The face tracker: detector + a tracker model (mesh, irises, blendshapes) + 68-point view.

The tracker model (:mod:`.landmarkers`: ``fast`` or ``full``) runs on the crop the tracker
chooses; detection, crops, presence and which face to follow are the tracker's, the same for
every model.

Tracking follows MediaPipe's video mode: once a face is found the next crop comes from the
previous frame's mesh and the detector is skipped. The detector runs again when the mesh's
presence score drops below ``min_presence`` (on the same frame, so a lost track costs no extra
frame) and every ``redetect_every`` frames as a check. With several faces the tracker follows
one performer: the largest (or best-scoring) face at first detection, then whichever detection
overlaps the face it is following.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import msgspec
import numpy as np

from .crops import CropRect
from .detector import Detection, FaceDetector, box_iou
from .ibug68 import mesh_to_ibug68
from .landmarkers import TRACKER_MODELS, Landmarks, TrackerModel, model_config
from .mesh import NUM_VERTICES, mesh_box, rect_from_detection, rect_from_mesh_box
from .model_files import DETECTOR, ModelSpec
from .model_input import frame_to_rgba
from .runtimes import Model, load_model, resolve_backend

__all__ = ["SELECT_MODES", "FaceTracker", "TrackResult"]

SELECT_MODES = ("largest", "score")
#: A periodic detection that overlaps the tracked face at least this much confirms the track
#: (the smoother mesh-derived crop is kept); a smaller but non-zero overlap re-anchors the crop
#: on the detection; no overlap at all leaves the track alone (the detector may miss an
#: occluded face, or see somebody else).
CONFIRM_IOU = 0.5
#: Crop hysteresis: while tracking, the mesh crop is only moved when the crop derived from the
#: new mesh differs from the current one by more than these (centre shift and size change as a
#: fraction of the side, roll in radians). Feeding the mesh back into its own crop otherwise
#: keeps a still face's crop — and so its points — wandering by up to a few pixels; with the
#: hold a still image gives identical points frame after frame.
HOLD_SHIFT = 0.02
HOLD_SCALE = 0.03
HOLD_ANGLE = math.radians(2.0)

_Box = tuple[float, float, float, float]


@dataclass(frozen=True, slots=True)
class TrackResult:
    """One frame's tracking result. All coordinates are frame pixels.

    Attributes:
        face: a face is being tracked on this frame. When False, every array is None.
        presence: the mesh model's face-presence score in [0, 1] (0.0 if it did not run).
        mesh: (468, 3) float32 — x, y, and z (relative depth in the same pixel scale).
        iris: (10, 2) float32 — subject's right eye (image left) centre + 4 contour points,
            then the left eye's; None also when the ``fast`` model runs with ``iris=False``.
        ibug68: (68, 2) float32 iBUG/CLM points (see :mod:`.ibug68`).
        box: (x, y, w, h) bounding box of the mesh.
        detected: the face detector ran on this frame.
        timings_ms: "detect", "mesh" (the tracker model's main call, crop included), "iris",
            "blendshapes" and "total" milliseconds for this frame (0.0 for a stage not run).
        mesh478: (478, 3) float32 — the ``full`` model's points (mesh, then both irises).
        blendshapes: (52,) float32 scores in [0, 1] (``full`` model with blendshapes).
    """

    face: bool
    presence: float
    mesh: np.ndarray | None = None
    iris: np.ndarray | None = None
    ibug68: np.ndarray | None = None
    box: _Box | None = None
    detected: bool = False
    timings_ms: dict[str, float] = field(default_factory=dict)
    mesh478: np.ndarray | None = None
    blendshapes: np.ndarray | None = None


def _xyxy(box: _Box) -> np.ndarray:
    x, y, w, h = box
    return np.array([x, y, x + w, y + h])


class FaceTracker:
    """Tracks one face through a stream of BGR frames. Not thread-safe: use one per stream."""

    def __init__(
        self,
        backend: str = "auto",
        redetect_every: int | None = 30,
        min_presence: float = 0.5,
        select: str = "largest",
        *,
        model: str | msgspec.Struct = "fast",
        iris: bool = True,
        num_threads: int = 1,
        min_detection_score: float = 0.5,
        model_dir: Path | str | None = None,
        verify_models: bool = True,
        hold_crop: bool = True,
    ) -> None:
        """Load the models.

        Args:
            backend: ``"auto"``, ``"litert"`` or ``"opencv"`` (see :mod:`.runtimes`).
            redetect_every: also run the detector every N tracked frames; None = only when the
                track is lost.
            min_presence: mesh presence score below which the face counts as lost.
            select: at first detection pick the ``"largest"`` face or the best ``"score"``.
            model: the tracker model (:mod:`.landmarkers`): a registered name (``"fast"``,
                ``"full"``) or its config struct.
            iris: with the ``fast`` model named by name, run the iris model (about half its
                per-frame cost); ignored otherwise.
            num_threads: LiteRT threads per model.
            min_detection_score: detector score threshold.
            model_dir: folder with the ``.tflite`` files (default: bundled).
            verify_models: check each file's SHA-256 against the bundled value.
            hold_crop: crop hysteresis while tracking (see :data:`HOLD_SHIFT`).

        Raises:
            ModelError: a model file is missing, unreadable or corrupt.
            ValueError: a bad argument (an unknown model: a PluginError).
        """
        if select not in SELECT_MODES:
            raise ValueError(f"select must be one of {SELECT_MODES}, got {select!r}")
        if redetect_every is not None and redetect_every < 1:
            raise ValueError("redetect_every must be >= 1 or None")
        if not 0.0 <= min_presence <= 1.0:
            raise ValueError("min_presence must be in [0, 1]")
        self.backend = resolve_backend(backend)
        self.redetect_every = redetect_every
        self.min_presence = min_presence
        self.select = select
        self.hold_crop = hold_crop
        config = model_config("fast", iris=iris) if model == "fast" else model_config(model)
        self.model_config = config

        def _load(spec: ModelSpec, batch: int = 1) -> Model:
            return load_model(
                spec,
                self.backend,
                model_dir=model_dir,
                num_threads=num_threads,
                batch=batch,
                verify=verify_models,
            )

        self.detector = FaceDetector(_load(DETECTOR), min_score=min_detection_score)
        self.model: TrackerModel = TRACKER_MODELS.build(config, _load)
        self._rgba: np.ndarray | None = None
        self.reset()

    def reset(self) -> None:
        """Forget the tracked face: the next frame runs the detector and picks afresh."""
        self._rect: CropRect | None = None
        self._box: _Box | None = None  # last known face box (kept after a loss, for stickiness)
        self._since_detect = 0

    @property
    def tracking(self) -> bool:
        """Whether a face is currently being tracked (the next frame may skip detection)."""
        return self._rect is not None

    # -- detection ------------------------------------------------------------------------

    def _pick(self, dets: list[Detection]) -> Detection | None:
        """Choose the detection to follow: the one overlapping the followed face, else (when
        not tracking) the largest / best scoring; None when tracking and nothing overlaps."""
        if self._box is not None:
            ious = box_iou(_xyxy(self._box), np.array([d.box for d in dets]))
            best = int(np.argmax(ious))
            if ious[best] > 0.0:
                return dets[best]
            if self._rect is not None:
                return None
        if self.select == "score":
            return max(dets, key=lambda d: d.score)
        return max(dets, key=lambda d: d.area)

    def _detect(self, frame: np.ndarray, timings: dict[str, float]) -> CropRect | None:
        t = time.perf_counter()
        dets = self.detector.detect_rgba(frame)
        timings["detect"] += (time.perf_counter() - t) * 1e3
        if not dets:
            return None
        det = self._pick(dets)
        if det is None:
            return None
        rect = rect_from_detection(det)
        if self._rect is not None and self._box is not None:
            iou = float(box_iou(_xyxy(self._box), np.array([det.box]))[0])
            if iou >= CONFIRM_IOU:
                return self._rect
        return rect

    def _run_mesh(
        self, frame: np.ndarray, rect: CropRect, timings: dict[str, float]
    ) -> tuple[np.ndarray, float]:
        t = time.perf_counter()
        points, presence = self.model.mesh(frame, rect)
        timings["mesh"] += (time.perf_counter() - t) * 1e3
        return points, presence

    # -- main entry -----------------------------------------------------------------------

    def process(self, image_bgr: np.ndarray) -> TrackResult:
        """Track the face in one uint8 BGR frame (BGRA and grey frames are accepted too).

        Raises:
            ValueError: not a uint8 image.
        """
        t0 = time.perf_counter()
        self._rgba = frame_to_rgba(image_bgr, self._rgba)
        return self.process_rgba(self._rgba, t0)

    def process_rgba(self, frame: np.ndarray, t0: float | None = None) -> TrackResult:
        """Track the face in one uint8 RGBA frame (H, W, 4), as decoded straight from a JPEG
        (:mod:`.jpeg_rgba`): :meth:`process` without its colour conversion. The frame is only
        read, and not kept past the call. ``t0``: when the frame's work began
        (``time.perf_counter``; default now), for ``timings["total"]``.

        Raises:
            ValueError: not a uint8 (H, W, 4) image.
        """
        if t0 is None:
            t0 = time.perf_counter()
        if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 4 or not frame.size:
            raise ValueError(f"expected a uint8 (H, W, 4) RGBA image, got {frame.shape}")
        timings = {"detect": 0.0, "mesh": 0.0, "iris": 0.0, "blendshapes": 0.0, "total": 0.0}

        detected = False
        rect = self._rect
        periodic = self.redetect_every is not None and self._since_detect >= self.redetect_every
        if rect is None or periodic:
            detected = True
            found = self._detect(frame, timings)
            if found is not None:
                rect = found
            if rect is None:
                return self._no_face(0.0, True, timings, t0)

        points, presence = self._run_mesh(frame, rect, timings)
        if presence < self.min_presence and not detected:
            # Lost while tracking: look for the face again on this very frame.
            detected = True
            self._rect = None
            found = self._detect(frame, timings)
            if found is None:
                return self._no_face(presence, True, timings, t0)
            rect = found
            points, presence = self._run_mesh(frame, rect, timings)
        if presence < self.min_presence:
            return self._no_face(presence, detected, timings, t0)

        extra: Landmarks = self.model.extras(frame, points, timings)
        mesh = points[:NUM_VERTICES]
        ibug = mesh_to_ibug68(mesh)

        box = mesh_box(mesh)
        self._rect = self._next_rect(rect, rect_from_mesh_box(mesh, box))
        self._box = box
        self._since_detect = 1 if detected else self._since_detect + 1
        timings["total"] = (time.perf_counter() - t0) * 1e3
        return TrackResult(
            True,
            presence,
            mesh,
            extra.iris,
            ibug,
            box,
            detected,
            timings,
            extra.mesh478,
            extra.blendshapes,
        )

    def _next_rect(self, current: CropRect, proposed: CropRect) -> CropRect:
        """Apply the crop hysteresis (see :data:`HOLD_SHIFT`)."""
        if not self.hold_crop:
            return proposed
        side = current.side
        d_angle = abs(math.remainder(proposed.angle - current.angle, math.tau))
        if (
            math.hypot(proposed.cx - current.cx, proposed.cy - current.cy) <= HOLD_SHIFT * side
            and abs(proposed.side - side) <= HOLD_SCALE * side
            and d_angle <= HOLD_ANGLE
        ):
            return current
        return proposed

    def _no_face(
        self, presence: float, detected: bool, timings: dict[str, float], t0: float
    ) -> TrackResult:
        self._rect = None
        self._since_detect = 0
        timings["total"] = (time.perf_counter() - t0) * 1e3
        return TrackResult(False, presence, detected=detected, timings_ms=timings)
