"""Named features on the real sample video, tracked by P's own tracker.

The performer (19.7 s, 472 frames): the first second, the neutral, is a sad face looking down;
then crying with eyes shut and a hand at the face (about frames 40-130); looking up with the
mouth a little open, hand at the mouth (160-210); then smiling and laughing with the head turned
to her left and chin up (about 230-440), the head tilted to her right shoulder (400-435); a
closed-mouth smile looking down to finish (440-472). The bounds below are what this recording
shows (see the numbers in each test), with margin, tracked with the ``fast`` model (468-point
mesh + iris model), whose features they were measured on. The ``full`` model's features on this
video are checked through the profiles (tests/integration/test_face_sections.py) and on
synthetic faces (tests/integration/test_face_sections_synthetic.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from sample_points import track_sample

from facesynth.runtime import codec
from facesynth.runtime.feature_names import LANDMARK_NAMES
from facesynth.schemas.messages import Features, Points
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.expressions import raw_features, relative
from facesynth.services.features.point_sets import ibug_points, optional_points


@pytest.fixture(scope="module")
def tracked() -> list[Points]:
    return track_sample("fast")


@pytest.fixture(scope="module")
def run(tracked: list[Points]) -> tuple[FeatureProcessor, list[Features]]:
    processor = FeatureProcessor()
    return processor, [processor.process(points) for points in tracked]


def _series(outs: list[Features], name: str) -> np.ndarray:
    return np.array([o.raw.get(name, np.nan) for o in outs])


def _mean(outs: list[Features], name: str, first: int, last: int) -> float:
    return float(np.nanmean(_series(outs, name)[first:last]))


def test_every_feature_once_the_neutral_is_known(run) -> None:
    _, outs = run
    ready = [i for i, o in enumerate(outs) if o.named]
    assert ready[0] == 24 and len(ready) == 472 - 24  # 23.98 fps: the first second is 24 frames
    for out in outs[24:]:
        codec.validate_features(out)
        assert set(out.named) == set(LANDMARK_NAMES) and len(out.displacements) == 136


def test_the_neutral_second_reads_about_zero(run, tracked) -> None:
    processor, _ = run
    assert processor.named_neutral is not None and processor.reference is not None
    rows = []
    for points in tracked[:24]:
        mesh = optional_points(points, "mesh468", 468, 3)
        iris = optional_points(points, "iris10", 10, 2)
        raw = raw_features(ibug_points(points), mesh, iris, processor.reference)
        rows.append(relative(raw, processor.named_neutral))
    for name in ("lip_corner_pull_right", "lip_corner_pull_left", "jaw_open", "lips_part"):
        assert abs(np.median([r[name] for r in rows])) < 0.01, name


def test_smile_and_laugh_pull_the_lip_corners(run) -> None:
    """Measured: laugh (290-400) +0.076 / +0.054, closed smile (440-472) +0.117 / +0.111."""
    _, outs = run
    for side in ("right", "left"):
        assert _mean(outs, f"lip_corner_pull_{side}", 290, 400) > 0.035
        assert _mean(outs, f"lip_corner_pull_{side}", 440, 472) > 0.08
        # and the corners are not read as depressed (measured +0.024 / -0.007)
        assert abs(_mean(outs, f"lip_corner_depress_{side}", 290, 400)) < 0.04
    assert _mean(outs, "lip_pucker", 440, 472) < -0.1, "a smile widens the mouth"


def test_laughing_opens_the_jaw_and_parts_the_lips(run) -> None:
    """Measured in the laugh: jaw_open +0.112, lips_part +0.115; closed smile: jaw -0.01."""
    _, outs = run
    assert _mean(outs, "jaw_open", 290, 400) > 0.07
    assert _mean(outs, "lips_part", 290, 400) > 0.07
    assert np.nanmax(_series(outs, "jaw_open")) > 0.12
    assert abs(_mean(outs, "jaw_open", 440, 472)) < 0.04


def test_vertical_gaze_follows_the_eyes(run) -> None:
    """Measured: looking up (160-210) +0.036 / +0.094, looking down (440-472) -0.041 / -0.044."""
    _, outs = run
    for side in ("right", "left"):
        assert _mean(outs, f"gaze_{side}_y", 160, 210) > 0.02
        assert _mean(outs, f"gaze_{side}_y", 440, 472) < -0.02
        # eyes wide open when looking up, after a half-lidded, downcast neutral (+0.064 / +0.066)
        assert _mean(outs, f"eye_open_{side}", 160, 210) > 0.03


def test_head_pose_follows_the_head(run) -> None:
    """Measured: yaw in the laugh +21 degrees, pitch looking up +11, roll at 400-432 -22."""
    _, outs = run
    assert _mean(outs, "head_yaw", 290, 400) > 12.0
    assert _mean(outs, "head_pitch", 160, 210) > 6.0
    assert _mean(outs, "head_roll", 400, 432) < -12.0
