"""Benchmark of the tracker models on a video (video decoding excluded from every timing).

For the CLI (``facesynth bench tracker [VIDEO]``): call :func:`bench_tracker` then print
:func:`format_bench`. For one-core figures run the process under ``taskset -c 0``; the bench
sets ``cv2.setNumThreads(1)`` and LiteRT uses one thread.

Every tracker model is timed with every inference backend; with ``mediapipe_python`` MediaPipe's
own trackers are timed too, in that interpreter (:mod:`.mediapipe_helper`, a child process with
the same CPU affinity), in the same run. With ``repeat`` > 1 the runs are interleaved (every
configuration once, then again) and each figure is the median over the runs, so a machine
whose speed drifts (shared cores) affects every configuration alike.
"""

from __future__ import annotations

import json
import os
import subprocess
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from facesynth.runtime.stats import memory_mb
from facesynth.services.points.tracker.model_input import frame_to_rgba
from facesynth.services.points.tracker.offline import iter_video_frames
from facesynth.services.points.tracker.tracker import FaceTracker

__all__ = [
    "GOALS",
    "GOAL_PEAK_RSS_MB",
    "MediaPipeError",
    "bench_tracker",
    "format_bench",
    "run_mediapipe",
]

#: Speed goals: our model -> (MediaPipe tracker it is compared with, how many times faster).
GOALS: dict[str, tuple[str, float]] = {
    "full": ("face_landmarker", 1.5),
    "fast": ("face_mesh_refined", 1.0),
}
MEDIAPIPE_LABELS = {
    "face_landmarker": "MediaPipe Face Landmarker task (478 points + blendshapes)",
    "face_mesh_refined": "MediaPipe legacy FaceMesh, refine_landmarks (478 points)",
}
GOAL_PEAK_RSS_MB = 200.0
#: Frames decoded ahead of timing (32 frames of 640x360 BGR = 22 MB).
CHUNK = 32
STAGES = ("detect", "mesh", "iris", "blendshapes", "models", "tracker", "detect_frame")
HELPER = Path(__file__).with_name("mediapipe_helper.py")


class MediaPipeError(ValueError):
    """MediaPipe's trackers could not be timed (bad interpreter, task file, or helper failure)."""


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
    tracker: FaceTracker, video: Path, frames: int | None, warmup: int
) -> dict[str, Any]:
    """One pass of ``tracker`` over the video."""
    tracker.reset()
    series: dict[str, list[float]] = {k: [] for k in STAGES if k != "detect"}
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
                for stage in ("mesh", "iris", "blendshapes"):
                    series[stage].append(tm[stage])
                series["models"].append(tm["mesh"] + tm["iris"] + tm["blendshapes"])
    out: dict[str, Any] = {k: _stats(v) for k, v in series.items()}
    out.update(frames=n, faces=faces, detector_runs=runs)
    return out


def _bench_detector(
    tracker: FaceTracker, video: Path, frames: int | None, warmup: int
) -> dict[str, float]:
    """The detector alone on every frame (its input conversion included), so its figures do
    not rest on the few frames where the tracker re-detects."""
    rgba: np.ndarray | None = None
    times: list[float] = []
    k = 0
    for chunk in _chunks(video, frames):
        for frame in chunk:
            t = time.perf_counter()
            rgba = frame_to_rgba(frame, rgba)
            tracker.detector.detect_rgba(rgba)
            k += 1
            if k > warmup:
                times.append((time.perf_counter() - t) * 1e3)
    return _stats(times)


def run_mediapipe(
    python: str, task: str, video: Path, frames: int | None, warmup: int
) -> dict[str, Any]:
    """Time MediaPipe's trackers with :mod:`.mediapipe_helper` in another interpreter.

    Raises:
        MediaPipeError: the interpreter or task file is missing, or the helper fails.
    """
    if not Path(task).is_file():
        raise MediaPipeError(f"MediaPipe task file not found: {task}")
    command = [python, str(HELPER), "--task", task, "--video", str(video)]
    command += ["--warmup", str(warmup)] + (["--frames", str(frames)] if frames else [])
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=600)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise MediaPipeError(f"cannot run {python}: {exc}") from None
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        tail = done.stderr.strip().splitlines()[-1:] or ["no output"]
        raise MediaPipeError(f"MediaPipe helper failed ({python}): {tail[0]}")
    try:
        result: dict[str, Any] = json.loads(lines[-1])
    except json.JSONDecodeError:
        raise MediaPipeError(f"MediaPipe helper printed no JSON ({python})") from None
    return result


def _median_of(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Stage statistics as the median over repeated runs (counts from the first run)."""
    out: dict[str, Any] = dict(runs[0])
    for key, value in runs[0].items():
        if isinstance(value, dict) and "median" in value:
            out[key] = {"n": value["n"]} | {
                stat: float(np.median([r[key][stat] for r in runs]))
                for stat in ("median", "p99", "mean")
            }
    return out


def bench_tracker(
    video_path: Path | str,
    backends: Sequence[str] = ("litert", "opencv"),
    frames: int | None = None,
    *,
    models: Sequence[str] = ("fast", "full"),
    redetect_every: int | None = 30,
    warmup: int = 5,
    repeat: int = 1,
    mediapipe_python: str | None = None,
    mediapipe_task: str | None = None,
) -> dict[str, Any]:
    """Measure every tracker model with every backend on a video (and MediaPipe, if asked).

    Per ``"model/backend"``: ``detect`` (the detector alone, on every frame), ``mesh`` (the
    model's main call), ``iris``, ``blendshapes`` and ``models`` (their sum) on tracked frames
    (where the detector is skipped), ``tracker`` (whole :meth:`FaceTracker.process`, every
    frame) and ``detect_frame`` (process() on frames where it re-detected), each as ``{"n",
    "median", "p99", "mean"}`` in ms; ``fps`` from the median tracker time; ``faces``,
    ``detector_runs``, ``load_ms``. The first ``warmup`` frames are left out. With
    ``repeat`` > 1, figures are medians over interleaved runs. ``mediapipe``: the helper's
    figures (same medians over runs), when ``mediapipe_python`` is given.

    Raises:
        VideoError: the video cannot be decoded completely (only checked when ``frames`` is None).
        MediaPipeError: MediaPipe's trackers could not be timed.
        ValueError: ``repeat`` < 1, or an unknown model or backend.
    """
    if repeat < 1:
        raise ValueError("--repeat must be at least 1")
    if mediapipe_python and not mediapipe_task:
        raise MediaPipeError("--mediapipe-python needs --mediapipe-task (face_landmarker.task)")
    if mediapipe_python and mediapipe_task and not Path(mediapipe_task).is_file():
        raise MediaPipeError(f"MediaPipe task file not found: {mediapipe_task}")
    cv2.setNumThreads(1)
    video = Path(video_path)
    cap = cv2.VideoCapture(str(video))
    size = (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)))
    cap.release()
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cpus = os.cpu_count() or 0
    trackers: dict[str, FaceTracker] = {}
    load_ms: dict[str, float] = {}
    for model in models:
        for backend in backends:
            t = time.perf_counter()
            trackers[f"{model}/{backend}"] = FaceTracker(
                backend=backend, redetect_every=redetect_every, model=model
            )
            load_ms[f"{model}/{backend}"] = (time.perf_counter() - t) * 1e3
    runs: dict[str, list[dict[str, Any]]] = {key: [] for key in trackers}
    mediapipe_runs: list[dict[str, Any]] = []
    for _ in range(repeat):
        for key, tracker in trackers.items():
            runs[key].append(_bench_one(tracker, video, frames, warmup))
        if mediapipe_python and mediapipe_task:
            mediapipe_runs.append(
                run_mediapipe(mediapipe_python, mediapipe_task, video, frames, warmup)
            )
    detect = {
        b: _bench_detector(trackers[f"{models[0]}/{b}"], video, frames, warmup) for b in backends
    }
    results: dict[str, Any] = {}
    for key, tracker in trackers.items():
        result = _median_of(runs[key])
        med = result["tracker"]["median"]
        result.update(
            model=tracker.model.name,
            backend=tracker.backend,
            detect=detect[tracker.backend],
            load_ms=load_ms[key],
            fps=1e3 / med if med > 0 else float("nan"),
        )
        results[key] = result
    mediapipe: dict[str, Any] = {}
    if mediapipe_runs:
        mediapipe = {"mediapipe": mediapipe_runs[0].get("mediapipe", "?")}
        for name in MEDIAPIPE_LABELS:
            mediapipe[name] = _median_of([r[name] for r in mediapipe_runs])
    return {
        "video": str(video),
        "size": size,
        "cpus_allowed": cpus,
        "cv2_threads": cv2.getNumThreads(),
        "redetect_every": redetect_every,
        "repeat": repeat,
        "results": results,
        "mediapipe": mediapipe,
        "peak_rss_mb": memory_mb()[1],
        "goals": {name: list(goal) for name, goal in GOALS.items()},
    }


def _speed_lines(result: dict[str, Any]) -> list[str]:
    """One line per speed goal: our best backend's median vs MediaPipe's."""
    lines = []
    mediapipe = result["mediapipe"]
    for model, (theirs, factor) in GOALS.items():
        ours = [r for r in result["results"].values() if r["model"] == model]
        if not ours:
            continue
        best = min(ours, key=lambda r: r["tracker"]["median"])
        mine = best["tracker"]["median"]
        if theirs not in mediapipe:
            lines.append(
                f"goal {model}: >= {factor:g}x faster than {MEDIAPIPE_LABELS[theirs]}: "
                f"{model}/{best['backend']} {mine:.3f} ms (no MediaPipe figure: "
                "give --mediapipe-python and --mediapipe-task)"
            )
            continue
        other = mediapipe[theirs]["per_frame_ms"]["median"]
        ratio = other / mine if mine > 0 else float("nan")
        verdict = "met" if ratio >= factor else f"NOT met, missed by {factor / ratio:.2f}x"
        lines.append(
            f"goal {model}: {model}/{best['backend']} {mine:.3f} ms vs {MEDIAPIPE_LABELS[theirs]} "
            f"{other:.3f} ms: {ratio:.2f}x faster (goal >= {factor:g}x: {verdict})"
        )
    return lines


def format_bench(result: dict[str, Any]) -> str:
    """Human-readable table of a :func:`bench_tracker` result."""
    w, h = result["size"]
    lines = [
        f"video {result['video']} ({w}x{h}), CPUs allowed: {result['cpus_allowed']}, "
        f"cv2 threads: {result['cv2_threads']}, re-detect every {result['redetect_every']}, "
        f"median of {result['repeat']} interleaved run(s)",
        f"{'model/backend':16} {'stage':12} {'median ms':>10} {'p99 ms':>9} {'n':>6}",
    ]
    for key, r in result["results"].items():
        for stage in STAGES:
            s = r[stage]
            if s["n"] == 0 or (stage in ("iris", "blendshapes") and s["median"] == 0.0):
                continue
            lines.append(f"{key:16} {stage:12} {s['median']:10.3f} {s['p99']:9.3f} {s['n']:6d}")
        lines.append(
            f"{key:16} {r['fps']:.0f} frames/s (median), faces {r['faces']}/{r['frames']}, "
            f"detector ran {r['detector_runs']}x, load {r['load_ms']:.0f} ms"
        )
    mediapipe = result["mediapipe"]
    for name, label in MEDIAPIPE_LABELS.items():
        if name in mediapipe:
            s = mediapipe[name]["per_frame_ms"]
            lines.append(
                f"{'mediapipe':16} {name:12} {s['median']:10.3f} {s['p99']:9.3f} {s['n']:6d}  "
                f"({label}, mediapipe {mediapipe['mediapipe']}, faces "
                f"{mediapipe[name]['faces']}/{mediapipe[name]['frames']})"
            )
    lines.extend(_speed_lines(result))
    lines.append(
        f"peak RSS {result['peak_rss_mb']:.0f} MB, this process with every tracker above loaded "
        f"(goal for one tracker <= {GOAL_PEAK_RSS_MB:.0f} MB)"
    )
    return "\n".join(lines)
