"""Make docs/learning.md's clip of the closed loop from a ``render --closed-loop`` video.

    facesynth render --robot-head simhead16 --profile runs/head.learned --closed-loop \\
        --max-frames 392 --out runs/closed.avi         # performer | closed loop | open loop
    pip install pillow                                 # docs only: not a facesynth dependency
    python docs/closed_loop_media.py runs/closed.avi

Writes ``docs/closed-loop-side-by-side.gif``: the laugh of the sample video (the frames
``docs/readme_media.py`` takes for the README's clip) at 8 fps, reduced, one shared palette.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
from PIL import Image
from readme_media import save_gif

CLIP = range(290, 390, 3)  # 4 s of the 24 fps video: she laughs
CLIP_WIDTH = 720
OUT = "closed-loop-side-by-side.gif"


def frames(path: str) -> list[Image.Image]:
    """The clip's frames of the video at ``path``, in order."""
    capture = cv2.VideoCapture(path)
    found: list[Image.Image] = []
    index = 0
    while index < CLIP.stop:
        ok, image = capture.read()
        if not ok:
            break
        if index in CLIP:
            found.append(Image.fromarray(cv2.cvtColor(image, cv2.COLOR_BGR2RGB)))
        index += 1
    capture.release()
    if len(found) != len(CLIP):
        raise SystemExit(f"{path}: {index} frames, the clip needs {CLIP.stop}")
    return found


def main(video: str) -> None:
    clip = frames(video)
    save_gif(clip, CLIP_WIDTH, colors=96, frame_ms=125, path=Path(__file__).parent / OUT)


if __name__ == "__main__":
    main(sys.argv[1])
