"""Make the README's screenshot and clip from the demo's side-by-side video.

    make demo                                   # writes facesynth-demo.mp4
    pip install pillow                          # docs only: not a facesynth dependency
    python docs/readme_media.py facesynth-demo.mp4

Writes ``docs/side-by-side.png`` (one frame, full size) and ``docs/side-by-side.gif`` (a few
seconds at reduced size and frame rate, with one shared palette, to stay small).
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
from PIL import Image

SHOT = 330  # a laugh: brows, cheeks, lip corners and jaw all move
CLIP = range(290, 386, 4)  # 4 s of the 24 fps video (a laugh and a head tilt) at 6 fps
CLIP_WIDTH = 480


def frames(path: str) -> dict[int, Image.Image]:
    wanted = {SHOT, *range(CLIP.start, CLIP.stop)}
    capture = cv2.VideoCapture(path)
    found: dict[int, Image.Image] = {}
    index = 0
    while index <= max(wanted):
        ok, image = capture.read()
        if not ok:
            break
        if index in wanted:
            found[index] = Image.fromarray(cv2.cvtColor(image, cv2.COLOR_BGR2RGB))
        index += 1
    capture.release()
    return found


def save_gif(clip: list[Image.Image], width: int, colors: int, frame_ms: int, path: Path) -> None:
    """Write ``clip`` as a looping GIF at ``width`` pixels, one palette (of its middle frame)."""
    height = round(clip[0].height * width / clip[0].width)
    small = [image.resize((width, height), Image.Resampling.LANCZOS) for image in clip]
    palette = small[len(small) // 2].quantize(colors=colors, method=Image.Quantize.MEDIANCUT)
    quantised = [image.quantize(palette=palette, dither=Image.Dither.NONE) for image in small]
    quantised[0].save(
        path,
        save_all=True,
        append_images=quantised[1:],
        duration=frame_ms,
        loop=0,
        optimize=True,
    )


def main(video: str) -> None:
    out = Path(__file__).parent
    images = frames(video)
    shot = images[SHOT].quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    shot.save(out / "side-by-side.png", optimize=True)
    clip = [images[i] for i in CLIP]
    save_gif(clip, CLIP_WIDTH, colors=64, frame_ms=167, path=out / "side-by-side.gif")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "facesynth-demo.mp4")
