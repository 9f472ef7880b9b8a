"""services.translator.core's state: determinism, reset, the stateless paper mapping, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from translator_fixtures import feature_servo, features_at, jaw_deltas, points_servo, profile_of

from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import Features
from facesynth.services.translator.core import TranslationError, Translator


def _random_session(seed: int) -> list[Features]:
    rng = np.random.default_rng(seed)
    frames = []
    for i in range(200):
        face = not 80 <= i < 110
        named = {"jaw_open": float(rng.normal(0, 0.5)), "gaze_right_y": float(rng.normal(0, 0.3))}
        if i % 17 == 0:
            named.pop("gaze_right_y")
        frames.append(features_at(i, named if face else None, rng.normal(0, 0.05, 68), face=face))
    return frames


@pytest.mark.parametrize("name", ["virtual", "paper16"])
def test_same_inputs_same_outputs_after_reset(name: str) -> None:
    translator = Translator(load_profile(name))
    frames = _random_session(5)
    first = [translator.step(frame) for frame in frames]
    translator.reset()
    second = [translator.step(frame) for frame in frames]
    fresh = Translator(load_profile(name))
    third = [fresh.step(frame) for frame in frames]
    assert first == second == third
    assert len({tuple(o.values()) for o in first}) > 100  # it did move


def test_without_reset_the_state_carries_over() -> None:
    translator = Translator(load_profile("virtual"))
    frames = _random_session(5)
    first = [translator.step(frame) for frame in frames]
    assert [translator.step(frame) for frame in frames] != first


def test_old_style_profile_is_the_paper_mapping_frame_by_frame() -> None:
    # Only points + face ranges, no smoothing or limits: the output is the stateless mapping,
    # also on repeated and backward timestamps.
    old = profile_of(
        points_servo("jaw", 0),
        feature_servo(
            "brow", 1, points=[17, 18, 19, 20], face_min=-0.06, face_max=0.08, reversed=True
        ),
    )
    translator = Translator(old)
    rng = np.random.default_rng(2)
    times = [0, 33, 66, 66, 100, 20, 133, 133]
    for index, t_ms in enumerate(times):
        deltas = rng.normal(0, 0.08, 68)
        expected = translator.positions(deltas)
        assert translator.step(features_at(index, deltas=deltas, t_ns=t_ms * 10**6)) == expected


def test_wrong_delta_count_leaves_the_state_alone() -> None:
    translator = Translator(profile_of(points_servo("s", max_speed=3000.0)))
    translator.step(features_at(0, deltas=jaw_deltas(0.2)))
    with pytest.raises(TranslationError, match="need 68 deltas, got 3"):
        translator.step(features_at(1, deltas=[0.0, 0.0, 0.0]))
    assert translator.step(features_at(1, deltas=jaw_deltas(0.2)))["s"] == 2000.0


def test_translate_carries_the_header() -> None:
    translator = Translator(profile_of(feature_servo()))
    commands = translator.translate(features_at(3, {"jaw_open": 0.5}))
    assert (commands.seq, commands.t_capture_ns, commands.t_media_ns, commands.face) == (
        3,
        7,
        100_000_000,
        True,
    )
    assert commands.profile == "t" and commands.positions == {"s": 1750.0}


def test_calibration_leaves_named_servos_alone() -> None:
    calibration = Calibration(
        name="c", neutral=[1.0] * 68, delta_min=[-0.5] * 68, delta_max=[0.5] * 68
    )
    translator = Translator(profile_of(feature_servo("a", 0), points_servo("b", 1)), calibration)
    assert translator._ranges == [(-1.0, 1.0), (-0.5, 0.5)]
    out = translator.step(features_at(0, {"jaw_open": 0.5}, jaw_deltas(0.25)))
    assert out == pytest.approx({"a": 1750.0, "b": 1750.0})
