"""Offline tracking of a video file to JSON Lines."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from .errors import VideoError
from .tracker import FaceTracker, TrackResult

__all__ = ["iter_video_frames", "result_to_record", "track_video"]


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


def result_to_record(frame: int, r: TrackResult) -> dict[str, Any]:
    """One JSON Lines record: frame index, face flag and 2-D points rounded to 0.01 px; with
    blendshapes (``full`` model) also ``"blendshapes"``: the 52 scores rounded to 0.0001."""
    record: dict[str, Any] = {
        "frame": frame,
        "face": r.face,
        "mesh": _points(r.mesh),
        "iris": _points(r.iris),
        "ibug68": _points(r.ibug68),
    }
    if r.blendshapes is not None:
        record["blendshapes"] = np.round(r.blendshapes.astype(np.float64), 4).tolist()
    return record


def track_video(
    path: Path | str,
    out_jsonl: Path | str,
    backend: str = "auto",
    *,
    tracker: FaceTracker | None = None,
    model: str | Any = "fast",
) -> dict[str, Any]:
    """Track every frame of a video and write one JSON line per frame, atomically.

    Each line is ``{"frame": i, "face": bool, "mesh": [[x, y] x 468] | null,
    "iris": [[x, y] x 10] | null, "ibug68": [[x, y] x 68] | null}`` in frame pixels (plus
    ``"blendshapes": [52 scores]`` on face lines of the ``full`` model). The file is
    written to a temporary file in the same folder, fsynced and renamed over ``out_jsonl``, so
    it is either complete or absent (an existing file is left untouched on error).

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
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent)
    tmp = Path(tmp_name)
    times: list[float] = []
    lost: list[int] = []
    faces = detections = frames = 0
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            for i, frame in enumerate(iter_video_frames(path)):
                t = time.perf_counter()
                r = trk.process(frame)
                times.append((time.perf_counter() - t) * 1e3)
                frames += 1
                faces += r.face
                detections += r.detected
                if not r.face:
                    lost.append(i)
                fh.write(json.dumps(result_to_record(i, r), separators=(",", ":")))
                fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, out)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    with contextlib.suppress(OSError):  # make the rename durable where the OS allows it
        dfd = os.open(out.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
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
