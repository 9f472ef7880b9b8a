"""Offline tracking of a video file to JSON Lines."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from facesynth.runtime.atomic import open_atomic
from facesynth.services.points.track_file import TrackLine, encode_line

from .errors import VideoError
from .tracker import FaceTracker, TrackResult

__all__ = ["iter_video_frames", "result_to_line", "track_video"]


def iter_video_frames(path: Path | str, max_frames: int | None = None) -> Iterator[np.ndarray]:
    """Yield the BGR frames of a video file, checking that it decodes completely.

    Raises:
        VideoError: the file is missing or cannot be opened, yields no frame, or stops before
            the frame count its container announces (truncated or corrupt data). The error is
            raised when the problem is found, possibly after some frames were yielded.
    """
    p = Path(path)
    if not p.is_file():
        raise VideoError(f"video not found: {p}")
    cap = cv2.VideoCapture(str(p))
    try:
        if not cap.isOpened():
            raise VideoError(f"cannot open video (corrupt or unsupported): {p}")
        expected = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        n = 0
        while max_frames is None or n < max_frames:
            ok, frame = cap.read()
            if not ok or frame is None:
                break
            n += 1
            yield frame
        if n == 0:
            raise VideoError(f"no frame could be decoded from {p} (corrupt or empty video)")
        if max_frames is None and expected > 0 and n < expected:
            raise VideoError(
                f"video truncated or corrupt: decoded {n} of {expected} frames from {p}"
            )
    finally:
        cap.release()


def _points(a: np.ndarray | None) -> list[list[float]] | None:
    if a is None:
        return None
    rounded: list[list[float]] = np.round(a[:, :2].astype(np.float64), 2).tolist()
    return rounded


def result_to_line(frame: int, r: TrackResult) -> TrackLine:
    """One track-file line: frame index, face flag, 2-D points rounded to 0.01 px, presence,
    and the blendshapes (``full`` model) rounded to 0.0001."""
    scores = r.blendshapes
    return TrackLine(
        frame=frame,
        face=r.face,
        mesh=_points(r.mesh),
        iris=_points(r.iris),
        ibug68=_points(r.ibug68),
        presence=round(float(r.presence), 4),
        blendshapes=None if scores is None else np.round(scores.astype(np.float64), 4).tolist(),
    )


def track_video(
    path: Path | str,
    out_jsonl: Path | str,
    backend: str = "auto",
    *,
    tracker: FaceTracker | None = None,
    model: str | Any = "fast",
) -> dict[str, Any]:
    """Track every frame of a video and write one JSON line per frame, atomically.

    Each line is a :class:`~services.points.track_file.TrackLine` (frame pixels). The file is
    written with :func:`~facesynth.runtime.atomic.open_atomic`, so it is either complete or
    absent (an existing file is left untouched on error).

    Args:
        path: the video.
        out_jsonl: output file.
        backend: inference backend for a new tracker.
        tracker: use this tracker instead (it is reset first).
        model: tracker model for a new tracker (a name or its config struct).

    Returns:
        ``{"video", "output", "backend", "frames", "faces", "lost_frames", "tracker_ms_median",
        "tracker_ms_p99", "detector_runs"}`` — timings exclude video decoding and writing.

    Raises:
        VideoError: missing, corrupt or truncated video.
        ModelError: a model file is missing or corrupt.
    """
    out = Path(out_jsonl)
    trk = tracker if tracker is not None else FaceTracker(backend=backend, model=model)
    trk.reset()
    times: list[float] = []
    lost: list[int] = []
    faces = detections = frames = 0
    with open_atomic(out) as fh:
        for i, frame in enumerate(iter_video_frames(path)):
            t = time.perf_counter()
            r = trk.process(frame)
            times.append((time.perf_counter() - t) * 1e3)
            frames += 1
            faces += r.face
            detections += r.detected
            if not r.face:
                lost.append(i)
            fh.write(encode_line(result_to_line(i, r)))
    arr = np.asarray(times)
    return {
        "video": str(path),
        "output": str(out),
        "backend": trk.backend,
        "model": trk.model.name,
        "frames": frames,
        "faces": faces,
        "lost_frames": lost,
        "detector_runs": detections,
        "tracker_ms_median": float(np.median(arr)),
        "tracker_ms_p99": float(np.percentile(arr, 99)),
    }
