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
    height = round(clip[0].height * CLIP_WIDTH / clip[0].width)
    small = [image.resize((CLIP_WIDTH, height), Image.Resampling.LANCZOS) for image in clip]
    palette = small[len(small) // 2].quantize(colors=96, method=Image.Quantize.MEDIANCUT)
    quantised = [image.quantize(palette=palette, dither=Image.Dither.NONE) for image in small]
    quantised[0].save(
        Path(__file__).parent / OUT,
        save_all=True,
        append_images=quantised[1:],
        duration=125,
        loop=0,
        optimize=True,
    )


if __name__ == "__main__":
    main(sys.argv[1])
