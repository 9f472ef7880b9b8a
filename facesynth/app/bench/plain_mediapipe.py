"""The plain script a user would write instead of facesynth, for ``facesynth bench run``.

A stand-alone script, never imported by facesynth: it runs in another Python that has
``mediapipe==0.10.21`` (numpy < 2, ~1 GB; not a facesynth dependency), e.g.::

    python3 -m venv /work/mpvenv && /work/mpvenv/bin/pip install mediapipe==0.10.21

One process, one loop, as fast as it goes: OpenCV decodes the video (one decoding thread, as
facesynth's video source decodes a video this small), MediaPipe's Face Landmarker task tracks
each frame (VIDEO mode, one face, blendshapes on, default confidences), a fixed linear map
turns the 52 blendshape scores into 16 servo positions (µs, clamped to 992..2000), and a
Pololu Maestro's compact-protocol Set Multiple Targets command (``0x9F 16 0`` then 16
quarter-µs targets, 7 bits at a time) is written to ``--out`` (a pipe or ``/dev/null``). With
no face the last positions are written again.

It prints one JSON object: ``cpu_ms_per_frame``, the process's user + system time over the
``--frames`` frames after ``--warmup`` frames (start-up, model loading and the warm-up left
out; every thread counted, MediaPipe's own included); ``model_calls_ms``, the process CPU
time spent inside ``detect_for_video`` on the same frames; ``wall_ms_per_frame``; the frames
with a face and the bytes written.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import time
from pathlib import Path
from typing import Any

import numpy as np

SERVOS = 16
#: Servo range in µs (a Maestro's default 992..2000) and the neutral pose.
MIN_US, MAX_US, NEUTRAL_US = 992.0, 2000.0, 1500.0


def linear_map(seed: int = 7) -> np.ndarray:
    """A fixed 16 x 52 map from blendshape scores to µs offsets from neutral."""
    return np.random.default_rng(seed).normal(0.0, 120.0, size=(SERVOS, 52))


def positions_us(weights: np.ndarray, scores: np.ndarray) -> np.ndarray:
    """The 16 servo positions (µs) of 52 blendshape scores: neutral plus the map, clamped."""
    return np.clip(NEUTRAL_US + weights @ scores, MIN_US, MAX_US)


def maestro_bytes(positions_us: np.ndarray) -> bytes:
    """Set Multiple Targets for channels 0..15, targets in quarter-µs, low 7 bits first."""
    quarters = np.rint(positions_us * 4.0).astype(np.int64)
    body = np.empty(2 * quarters.size, dtype=np.uint8)
    body[0::2] = quarters & 0x7F
    body[1::2] = (quarters >> 7) & 0x7F
    return bytes((0x9F, quarters.size, 0)) + body.tobytes()


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _open_video(video: Path) -> Any:
    import cv2

    cap = cv2.VideoCapture(str(video), cv2.CAP_FFMPEG, [cv2.CAP_PROP_N_THREADS, 1])
    if not cap.isOpened():
        cap = cv2.VideoCapture(str(video))
    if not cap.isOpened():
        raise SystemExit(f"cannot open {video} as a video")
    return cap


def run(task: Path, video: Path, frames: int, warmup: int, out: Path) -> dict[str, Any]:
    """The loop, timed; see the module's docstring for what it returns."""
    # Imported here, so that the pure parts above load without MediaPipe (tests check them).
    import cv2
    import mediapipe as mp
    from mediapipe.tasks.python import BaseOptions, vision

    options = vision.FaceLandmarkerOptions(
        base_options=BaseOptions(model_asset_path=str(task)),
        running_mode=vision.RunningMode.VIDEO,
        num_faces=1,
        output_face_blendshapes=True,
    )
    weights = linear_map()
    positions = np.full(SERVOS, NEUTRAL_US)
    cap = _open_video(video)
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    sink = os.open(out, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    faces = written = 0
    model_s = 0.0
    cpu0 = wall0 = 0.0
    try:
        with vision.FaceLandmarker.create_from_options(options) as landmarker:
            for index in range(warmup + frames):
                if index == warmup:  # a frame boundary: start-up and warm-up end here
                    cpu0, wall0, model_s, faces, written = _cpu_s(), time.perf_counter(), 0.0, 0, 0
                ok, bgr = cap.read()
                if not ok:
                    raise SystemExit(f"{video} ended after {index} frames")
                rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
                image = mp.Image(image_format=mp.ImageFormat.SRGB, data=rgb)
                start = time.process_time()
                result = landmarker.detect_for_video(image, round(index * 1000.0 / fps))
                model_s += time.process_time() - start
                if result.face_blendshapes:
                    faces += 1
                    scores = np.fromiter(
                        (c.score for c in result.face_blendshapes[0]), dtype=np.float64, count=52
                    )
                    positions = positions_us(weights, scores)
                written += os.write(sink, maestro_bytes(positions))
            cpu, wall = _cpu_s() - cpu0, time.perf_counter() - wall0
    finally:
        os.close(sink)
        cap.release()
    return {
        "script": "plain_mediapipe",
        "mediapipe": mp.__version__,
        "frames": frames,
        "warmup": warmup,
        "faces": faces,
        "cpu_ms_per_frame": cpu * 1e3 / frames,
        "model_calls_ms": model_s * 1e3 / frames,
        "wall_ms_per_frame": wall * 1e3 / frames,
        "bytes": written,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", type=Path, required=True, help="face_landmarker.task")
    parser.add_argument("--video", type=Path, required=True)
    parser.add_argument("--frames", type=int, required=True, help="frames measured")
    parser.add_argument("--warmup", type=int, default=30, help="frames before the measured ones")
    parser.add_argument("--out", type=Path, default=Path(os.devnull), help="Maestro bytes to")
    args = parser.parse_args()
    if args.frames < 1 or args.warmup < 0:
        raise SystemExit("--frames must be at least 1 and --warmup at least 0")
    print(json.dumps(run(args.task, args.video, args.frames, args.warmup, args.out)))


if __name__ == "__main__":
    main()
