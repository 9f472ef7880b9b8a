"""Benchmark of the tracker on a video file (video decoding excluded from every timing).

For the CLI (``facesynth bench tracker VIDEO``): call :func:`bench_tracker` then print
:func:`format_bench`. For one-core figures run the process under ``taskset -c 0``; the bench
sets ``cv2.setNumThreads(1)`` and LiteRT uses one thread.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from facesynth.runtime.stats import memory_mb
from services.points.tracker.model_input import frame_to_rgba
from services.points.tracker.offline import iter_video_frames
from services.points.tracker.tracker import FaceTracker

__all__ = ["GOAL_MESH_IRIS_MS", "GOAL_PEAK_RSS_MB", "bench_tracker", "format_bench"]

GOAL_MESH_IRIS_MS = 2.0
GOAL_PEAK_RSS_MB = 200.0
#: Frames decoded ahead of timing (32 frames of 640x360 BGR = 22 MB).
CHUNK = 32


def _stats(values: Sequence[float]) -> dict[str, float]:
    if not values:
        return {"n": 0, "median": float("nan"), "p99": float("nan"), "mean": float("nan")}
    a = np.asarray(values, dtype=np.float64)
    return {
        "n": int(a.size),
        "median": float(np.median(a)),
        "p99": float(np.percentile(a, 99)),
        "mean": float(a.mean()),
    }


def _chunks(video: Path, frames: int | None) -> Iterator[list[np.ndarray]]:
    """Decoded frames in groups of :data:`CHUNK`: each group is decoded before it is timed, so
    the decoder neither counts nor evicts the models from the CPU caches mid-run."""
    chunk: list[np.ndarray] = []
    for frame in iter_video_frames(video, frames):
        chunk.append(frame)
        if len(chunk) == CHUNK:
            yield chunk
            chunk = []
    if chunk:
        yield chunk


def _bench_one(
    video: Path, backend: str, frames: int | None, redetect_every: int | None, warmup: int
) -> dict[str, Any]:
    t = time.perf_counter()
    tracker = FaceTracker(backend=backend, redetect_every=redetect_every)
    load_ms = (time.perf_counter() - t) * 1e3
    series: dict[str, list[float]] = {
        k: [] for k in ("detect", "mesh", "iris", "mesh_iris", "tracker", "detect_frame")
    }
    faces = runs = n = 0
    for chunk in _chunks(video, frames):
        for frame in chunk:
            r = tracker.process(frame)
            faces += r.face
            runs += r.detected
            n += 1
            if n <= warmup:
                continue
            tm = r.timings_ms
            series["tracker"].append(tm["total"])
            if r.detected:
                series["detect_frame"].append(tm["total"])
            elif r.face:
                series["mesh"].append(tm["mesh"])
                series["iris"].append(tm["iris"])
                series["mesh_iris"].append(tm["mesh"] + tm["iris"])
    # The detector alone on every frame (its input conversion included), in a second pass, so
    # its figures do not rest on the few frames where the tracker re-detects.
    rgba: np.ndarray | None = None
    k = 0
    for chunk in _chunks(video, frames):
        for frame in chunk:
            t = time.perf_counter()
            rgba = frame_to_rgba(frame, rgba)
            tracker.detector.detect_rgba(rgba)
            k += 1
            if k > warmup:
                series["detect"].append((time.perf_counter() - t) * 1e3)
    out: dict[str, Any] = {k: _stats(v) for k, v in series.items()}
    med = out["tracker"]["median"]
    out.update(
        backend=tracker.backend,
        frames=n,
        faces=faces,
        detector_runs=runs,
        load_ms=load_ms,
        fps=1e3 / med if med > 0 else float("nan"),
    )
    return out


def bench_tracker(
    video_path: Path | str,
    backends: Sequence[str] = ("litert", "opencv"),
    frames: int | None = None,
    *,
    redetect_every: int | None = 30,
    warmup: int = 5,
) -> dict[str, Any]:
    """Measure the tracker per backend on a video.

    Per backend: ``detect`` (the detector alone, on every frame), ``mesh``, ``iris`` and
    ``mesh_iris`` (on tracked frames, where the detector is skipped), ``tracker`` (whole
    :meth:`FaceTracker.process`, every frame) and ``detect_frame`` (process() on frames where it
    re-detected), each as ``{"n", "median", "p99", "mean"}`` in ms; ``fps`` from the median
    tracker time; ``faces``, ``detector_runs``, ``load_ms``. The first ``warmup`` frames are left
    out of the statistics. Frames are decoded :data:`CHUNK` at a time ahead of the timed
    calls. Also reported: the process's peak RSS and the goals.

    Raises:
        VideoError: the video cannot be decoded completely (only checked when ``frames`` is None).
    """
    cv2.setNumThreads(1)
    video = Path(video_path)
    cap = cv2.VideoCapture(str(video))
    size = (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)))
    cap.release()
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cpus = os.cpu_count() or 0
    results = {b: _bench_one(video, b, frames, redetect_every, warmup) for b in backends}
    return {
        "video": str(video),
        "size": size,
        "cpus_allowed": cpus,
        "cv2_threads": cv2.getNumThreads(),
        "redetect_every": redetect_every,
        "backends": results,
        "peak_rss_mb": memory_mb()[1],
        "goal": {"mesh_iris_median_ms": GOAL_MESH_IRIS_MS, "peak_rss_mb": GOAL_PEAK_RSS_MB},
    }


def format_bench(result: dict[str, Any]) -> str:
    """Human-readable table of a :func:`bench_tracker` result."""
    w, h = result["size"]
    lines = [
        f"video {result['video']} ({w}x{h}), CPUs allowed: {result['cpus_allowed']}, "
        f"cv2 threads: {result['cv2_threads']}, re-detect every {result['redetect_every']}",
        f"{'backend':8} {'stage':12} {'median ms':>10} {'p99 ms':>9} {'n':>6}",
    ]
    for name, r in result["backends"].items():
        for stage in ("detect", "mesh", "iris", "mesh_iris", "tracker", "detect_frame"):
            s = r[stage]
            lines.append(f"{name:8} {stage:12} {s['median']:10.3f} {s['p99']:9.3f} {s['n']:6d}")
        lines.append(
            f"{name:8} {r['fps']:.0f} frames/s (median), faces {r['faces']}/{r['frames']}, "
            f"detector ran {r['detector_runs']}x, load {r['load_ms']:.0f} ms"
        )
    goal = result["goal"]
    best = min(r["mesh_iris"]["median"] for r in result["backends"].values())
    lines.append(
        f"goal mesh+iris median <= {goal['mesh_iris_median_ms']} ms: best {best:.3f} ms "
        f"({'met' if best <= goal['mesh_iris_median_ms'] else 'NOT met'}); "
        f"peak RSS {result['peak_rss_mb']:.0f} MB (goal <= {goal['peak_rss_mb']:.0f} MB)"
    )
    return "\n".join(lines)
