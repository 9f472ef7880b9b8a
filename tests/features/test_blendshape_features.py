"""Blendshapes (``full`` tracker model) as F's named features: neutral, range, calibration."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest
from synthetic_face import IRIS, MESH, S, points_message

from facesynth.runtime import blendshapes, codec
from facesynth.runtime.feature_names import BLENDSHAPE_NAMES, BY_NAME, LANDMARK_NAMES, NAMES
from facesynth.schemas.messages import Features, Points, ScoreSet
from facesynth.services.features.calibrate import CalibrationRecorder
from facesynth.services.features.core import FeatureError, FeatureProcessor
from facesynth.services.features.expressions import raw_features
from facesynth.services.features.point_sets import blendshape_scores

FPS = 30
REST = np.full(blendshapes.COUNT, 0.1)


def _scores(**shapes: float) -> np.ndarray:
    out = REST.copy()
    for name, value in shapes.items():
        out[blendshapes.INDEX[name]] = value
    return out


def _message(scores: np.ndarray | None, seq: int) -> Points:
    points = points_message(MESH, IRIS, seq=seq, t_media_ns=seq * S // FPS)
    if scores is not None:
        values = scores.tolist()
        scores = [ScoreSet(scheme=blendshapes.BLENDSHAPES52, values=values)]
        points = msgspec.structs.replace(points, scores=scores)
    return points


def _feed(processor: FeatureProcessor, scores: list[np.ndarray | None]) -> list[Features]:
    out = []
    for seq, frame_scores in enumerate(scores):
        features = processor.process(_message(frame_scores, seq))
        codec.validate_features(features)
        out.append(features)
    return out


def test_the_51_shapes_are_named_features() -> None:
    assert len(BLENDSHAPE_NAMES) == 51 and "_neutral" not in BLENDSHAPE_NAMES
    assert set(NAMES) == set(LANDMARK_NAMES) | BLENDSHAPE_NAMES
    assert not BLENDSHAPE_NAMES & set(LANDMARK_NAMES)
    assert BY_NAME["mouthSmileLeft"].default_min == -0.5
    assert BY_NAME["mouthSmileLeft"].default_max == 0.5


def test_blendshapes_are_relative_to_the_neutral_and_scaled() -> None:
    processor = FeatureProcessor()
    smile = _scores(mouthSmileLeft=0.35, mouthSmileRight=0.6, jawOpen=0.0)
    outs = _feed(processor, [REST] * (FPS + 1) + [smile])
    neutral, last = outs[FPS], outs[-1]
    assert set(neutral.named) == set(NAMES)
    assert max(abs(neutral.named[name]) for name in BLENDSHAPE_NAMES) < 1e-9
    assert last.raw["mouthSmileLeft"] == pytest.approx(0.25)
    assert last.named["mouthSmileLeft"] == pytest.approx(0.5)
    assert last.named["mouthSmileRight"] == pytest.approx(1.0)
    assert last.named["jawOpen"] == pytest.approx(-0.2)  # below the neutral's 0.1
    assert last.named["browInnerUp"] == pytest.approx(0.0)


def test_without_blendshapes_there_are_none() -> None:
    outs = _feed(FeatureProcessor(), [None] * (FPS + 2))
    assert set(outs[-1].named) == set(LANDMARK_NAMES)


def test_a_calibration_gives_blendshape_ranges() -> None:
    recorder = CalibrationRecorder("dana", raw_features, settle_s=0.0)
    for i in range(10):
        recorder.add("neutral", i / FPS, _message(_scores(mouthSmileLeft=0.2), i))
        recorder.add("smile", i / FPS, _message(_scores(mouthSmileLeft=0.2 + 0.06 * i), i))
    calibration = recorder.build()
    assert calibration.named_neutral["mouthSmileLeft"] == pytest.approx(0.2)
    assert calibration.named_max["mouthSmileLeft"] == pytest.approx(0.513, abs=0.01)
    # a shape that did not move keeps a share of the default range
    assert calibration.named_max["jawOpen"] == pytest.approx(0.125)
    processor = FeatureProcessor.from_calibration(calibration)
    outs = _feed(
        processor, [_scores(mouthSmileLeft=0.2)] * (FPS + 1) + [_scores(mouthSmileLeft=0.5)]
    )
    assert outs[-1].named["mouthSmileLeft"] == pytest.approx(0.3 / 0.513, abs=0.02)


def test_auto_range_widens_a_blendshape() -> None:
    processor = FeatureProcessor(auto_range=True)
    wide = _scores(mouthSmileLeft=0.9)
    outs = _feed(processor, [REST] * (FPS + 1) + [wide] * 5)
    assert outs[-1].raw["mouthSmileLeft"] == pytest.approx(0.8)
    assert outs[-1].named["mouthSmileLeft"] == pytest.approx(1.0)  # the range grew to 0.8


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ([0.5] * 51, "blendshapes52 set has 51 values"),
        ([0.5] * 51 + [1.5], "not a number in 0..1"),
        ([0.5] * 51 + [float("nan")], "not a number in 0..1"),
    ],
)
def test_malformed_blendshapes_are_refused(values: list[float], message: str) -> None:
    scores = [ScoreSet(scheme=blendshapes.BLENDSHAPES52, values=values)]
    points = msgspec.structs.replace(_message(None, 0), scores=scores)
    with pytest.raises(FeatureError, match=message):
        blendshape_scores(points)
    with pytest.raises(FeatureError, match=message):
        FeatureProcessor().process(points)


def test_malformed_blendshapes_do_not_stop_a_calibration() -> None:
    recorder = CalibrationRecorder("erin", raw_features, settle_s=0.0)
    scores = [ScoreSet(scheme=blendshapes.BLENDSHAPES52, values=[2.0] * 52)]
    bad = msgspec.structs.replace(_message(None, 0), scores=scores)
    assert recorder.add("neutral", 0.0, bad)
    for i in range(1, 4):
        recorder.add("neutral", i / FPS, _message(REST, i))
    assert recorder.build().named_neutral["jawOpen"] == pytest.approx(0.1)
