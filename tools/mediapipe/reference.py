"""Run MediaPipe's own Face Landmarker task on a video and save its landmarks and blendshapes.

NOT part of facesynth and not run by CI: it needs ``mediapipe==0.10.21`` (numpy < 2, ~1 GB),
which is not a facesynth dependency. Run it once, in its own venv, to (re)make the reference
file that ``tests/points/tracker/test_agreement_mediapipe.py`` compares facesynth's ``full``
tracker model with::

    python3 -m venv /work/mpvenv && /work/mpvenv/bin/pip install mediapipe==0.10.21
    /work/mpvenv/bin/python tools/mediapipe/reference.py \\
        --task /work/shared/models/face_landmarker.task \\
        --video facesynth/app/data/WolfgangLanger_Pexels.mp4 \\
        --out tests/points/tracker/reference/mediapipe_face_landmarker.npz

Its speed is measured by ``facesynth/app/bench/mediapipe_helper.py`` (``facesynth bench
tracker --mediapipe-python``). The task runs in VIDEO mode (tracking, detector skipped while
the face is tracked), one face, blendshapes on, default confidences (0.5). Saved (compressed
``.npz``):

* ``frames`` (n,) int32: the frame indices kept (every ``--every``-th frame);
* ``face`` (n,) bool: a face was found;
* ``xy`` (n, 478, 2) int16: landmark x, y in frame pixels times ``XY_SCALE`` (1/16 px steps);
* ``blendshapes`` (n, 52) float16: the 52 scores in the model's (ARKit) order;
* ``names`` (52,) str: the blendshape names as MediaPipe reports them;
* ``meta``: a JSON string (mediapipe version, task and video sha256, video size, mode).
"""

from __future__ import annotations

import argparse
import hashlib
import json
from pathlib import Path

import cv2
import mediapipe as mp
import numpy as np
from mediapipe.tasks.python import BaseOptions, vision

XY_SCALE = 16.0


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", type=Path, required=True, help="face_landmarker.task")
    parser.add_argument("--video", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True, help="output .npz")
    parser.add_argument("--every", type=int, default=1, help="keep every N-th frame (default 1)")
    parser.add_argument("--mode", choices=("video", "image"), default="video")
    args = parser.parse_args()

    mode = vision.RunningMode.VIDEO if args.mode == "video" else vision.RunningMode.IMAGE
    options = vision.FaceLandmarkerOptions(
        base_options=BaseOptions(model_asset_path=str(args.task)),
        running_mode=mode,
        num_faces=1,
        output_face_blendshapes=True,
    )
    cap = cv2.VideoCapture(str(args.video))
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    width = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
    height = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    frames, faces, xys, scores = [], [], [], []
    names: list[str] = []
    with vision.FaceLandmarker.create_from_options(options) as landmarker:
        index = 0
        while True:
            ok, bgr = cap.read()
            if not ok:
                break
            image = mp.Image(
                image_format=mp.ImageFormat.SRGB, data=cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
            )
            if mode == vision.RunningMode.VIDEO:
                result = landmarker.detect_for_video(image, round(index * 1000.0 / fps))
            else:
                result = landmarker.detect(image)
            if index % args.every == 0:
                frames.append(index)
                face = bool(result.face_landmarks)
                faces.append(face)
                xy = np.zeros((478, 2))
                bs = np.zeros(52)
                if face:
                    xy = np.array([(p.x * width, p.y * height) for p in result.face_landmarks[0]])
                    bs = np.array([c.score for c in result.face_blendshapes[0]])
                    names = [c.category_name for c in result.face_blendshapes[0]]
                xys.append(np.round(xy * XY_SCALE).astype(np.int16))
                scores.append(bs.astype(np.float16))
            index += 1
    cap.release()
    meta = {
        "mediapipe": mp.__version__,
        "task_sha256": _sha256(args.task),
        "video": args.video.name,
        "video_sha256": _sha256(args.video),
        "size": [width, height],
        "fps": fps,
        "mode": args.mode,
        "every": args.every,
        "xy_scale": XY_SCALE,
        "frames_read": index,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(
        args.out,
        frames=np.array(frames, np.int32),
        face=np.array(faces, bool),
        xy=np.stack(xys),
        blendshapes=np.stack(scores),
        names=np.array(names),
        meta=np.array(json.dumps(meta)),
    )
    print(json.dumps({**meta, "faces": int(sum(faces)), "out": str(args.out)}))


if __name__ == "__main__":
    main()
