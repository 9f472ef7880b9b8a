"""Time MediaPipe's own face trackers on a video, for ``facesynth bench tracker``.

A stand-alone script, never imported by facesynth: it runs in another Python that has
``mediapipe==0.10.21`` (numpy < 2, ~1 GB; not a facesynth dependency), e.g.::

    python3 -m venv /work/mpvenv && /work/mpvenv/bin/pip install mediapipe==0.10.21

``facesynth bench tracker --mediapipe-python /work/mpvenv/bin/python --mediapipe-task
face_landmarker.task`` runs this file with that interpreter (same CPU affinity, as a child
process) and prints its figures beside facesynth's. It prints one JSON object: per tracker,
the per-frame call time (median, p99, mean, n) in ms, frames with a face, and the frame count.

Trackers timed (one face, video mode, default confidences, one frame at a time):

* ``face_landmarker``: the Face Landmarker task (``face_landmarker.task``: BlazeFace, the v2
  478-point model, blendshapes on), ``detect_for_video``;
* ``face_mesh_refined``: the legacy FaceMesh solution with ``refine_landmarks=True`` (478
  points: the attention mesh with irises), ``process``.

Frames are decoded ``CHUNK`` at a time before they are timed; the RGB conversion and the
``mp.Image`` wrapping are outside the timed call.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import cv2
import mediapipe as mp
import numpy as np
from mediapipe.tasks.python import BaseOptions, vision

CHUNK = 32


def _chunks(video: Path, frames: int | None) -> Iterator[list[np.ndarray]]:
    cap = cv2.VideoCapture(str(video))
    if not cap.isOpened():
        raise SystemExit(f"cannot open {video}")
    chunk: list[np.ndarray] = []
    n = 0
    while frames is None or n < frames:
        ok, bgr = cap.read()
        if not ok:
            break
        chunk.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        n += 1
        if len(chunk) == CHUNK:
            yield chunk
            chunk = []
    if chunk:
        yield chunk
    cap.release()


def _stats(values: list[float]) -> dict[str, float]:
    a = np.asarray(values, dtype=np.float64)
    return {
        "n": int(a.size),
        "median": float(np.median(a)),
        "p99": float(np.percentile(a, 99)),
        "mean": float(a.mean()),
    }


def _time(
    video: Path, frames: int | None, warmup: int, call: Callable[[np.ndarray, int], bool]
) -> dict[str, Any]:
    times: list[float] = []
    faces = n = 0
    for chunk in _chunks(video, frames):
        for rgb in chunk:
            t = time.perf_counter()
            face = call(rgb, n)
            elapsed = (time.perf_counter() - t) * 1e3
            faces += face
            n += 1
            if n > warmup:
                times.append(elapsed)
    return {"per_frame_ms": _stats(times), "faces": faces, "frames": n}


def bench_face_landmarker(
    task: Path, video: Path, frames: int | None, warmup: int
) -> dict[str, Any]:
    options = vision.FaceLandmarkerOptions(
        base_options=BaseOptions(model_asset_path=str(task)),
        running_mode=vision.RunningMode.VIDEO,
        num_faces=1,
        output_face_blendshapes=True,
    )
    with vision.FaceLandmarker.create_from_options(options) as landmarker:

        def call(rgb: np.ndarray, index: int) -> bool:
            image = mp.Image(image_format=mp.ImageFormat.SRGB, data=rgb)
            result = landmarker.detect_for_video(image, index * 42)
            return bool(result.face_landmarks) and bool(result.face_blendshapes)

        return _time(video, frames, warmup, call)


def bench_face_mesh(video: Path, frames: int | None, warmup: int) -> dict[str, Any]:
    with mp.solutions.face_mesh.FaceMesh(
        static_image_mode=False, max_num_faces=1, refine_landmarks=True
    ) as mesh:

        def call(rgb: np.ndarray, index: int) -> bool:
            return bool(mesh.process(rgb).multi_face_landmarks)

        return _time(video, frames, warmup, call)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", type=Path, required=True, help="face_landmarker.task")
    parser.add_argument("--video", type=Path, required=True)
    parser.add_argument("--frames", type=int, default=None)
    parser.add_argument("--warmup", type=int, default=5)
    args = parser.parse_args()
    out = {
        "mediapipe": mp.__version__,
        "cpus_allowed": len(os.sched_getaffinity(0)),
        "face_landmarker": bench_face_landmarker(args.task, args.video, args.frames, args.warmup),
        "face_mesh_refined": bench_face_mesh(args.video, args.frames, args.warmup),
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
