"""Brow controls over the sample video's smiles and laughs (issue 20: the demo face frowned).

    python tools/brows_at_laugh.py

Tracks the bundled video with the ``full`` model in this process (as ``bench fidelity`` does),
then runs F (no calibration) and T of each profile, and prints, over the frames after the first
second where the performer smiles or laughs (mean mouthSmile >= 0.5) while the tracker's own
brow blendshapes say her brows are at rest (browDown*, browInnerUp, browOuterUp* <= 0.2), each
brow servo's median position (share of its travel from neutral: -1 fully lowered, +1 fully
raised), the share of frames within +-0.25 of neutral and the share at -0.5 or lower. Run it on
another checkout (``PYTHONPATH=THAT python tools/brows_at_laugh.py``) to compare.
"""

from __future__ import annotations

import sys

import cv2
import numpy as np

from facesynth.app.data import sample_video
from facesynth.runtime import blendshapes
from facesynth.runtime.frames import encode_frame
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import Points
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.point_sets import blendshape_scores
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig
from facesynth.services.translator.core import Translator

PROFILES = ("virtual", "virtual_bs", "head16", "paper16")
BROW_SHAPES = (
    "browDownLeft",
    "browDownRight",
    "browInnerUp",
    "browOuterUpLeft",
    "browOuterUpRight",
)


def track() -> list[Points]:
    capture = cv2.VideoCapture(str(sample_video()))
    fps = capture.get(cv2.CAP_PROP_FPS)
    backend = TrackerBackend(TrackerConfig(model="full"))
    points: list[Points] = []
    while True:
        ok, image = capture.read()
        if not ok:
            break
        t = round(len(points) * 1e9 / fps)
        frame = encode_frame(image, seq=len(points), t_capture_ns=t, t_media_ns=t, encoding="raw")
        points.append(backend.process(frame))
    capture.release()
    return points


def chosen_frames(points: list[Points]) -> np.ndarray:
    """Smiling or laughing, brow blendshapes at rest, after the first second (24 frames)."""
    chosen = []
    for i, message in enumerate(points):
        scores = blendshape_scores(message)
        if scores is None:
            chosen.append(False)
            continue
        score = {name: float(scores[blendshapes.INDEX[name]]) for name in blendshapes.NAMES}
        smile = (score["mouthSmileLeft"] + score["mouthSmileRight"]) / 2
        rest = max(score[name] for name in BROW_SHAPES) <= 0.2
        chosen.append(i >= 24 and smile >= 0.5 and rest)
    return np.asarray(chosen)


def main() -> int:
    points = track()
    chosen = chosen_frames(points)
    laugh = chosen & (np.arange(len(points)) >= 230)
    print(f"{chosen.sum()} frames chosen, {laugh.sum()} of them in the laugh (from frame 230)")
    for name in PROFILES:
        profile = load_profile(name)
        processor = FeatureProcessor(neutral_seconds=profile.neutral_seconds)
        translator = Translator(profile)
        positions = [translator.step(processor.process(p)) for p in points]
        for spec in profile.servos:
            if "brow" not in spec.name:
                continue
            values = np.array([p[spec.name] for p in positions]) - spec.neutral_us
            span = np.where(
                values >= 0, spec.max_us - spec.neutral_us, spec.neutral_us - spec.min_us
            )
            travel = values / span
            for label, frames in (("all", chosen), ("laugh", laugh)):
                t = travel[frames]
                print(
                    f"{name:10} {spec.name:15} {label:5} median {np.median(t):+.2f}  "
                    f"within +-0.25: {np.mean(np.abs(t) <= 0.25):4.0%}  "
                    f"at -0.5 or lower: {np.mean(t <= -0.5):4.0%}"
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
