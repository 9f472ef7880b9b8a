"""services.translator.core over time: neutral ramps on face loss and return, rate limits."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from translator_fixtures import DT, TOL, feature_servo, features_at, positions_of, profile_of

from facesynth.runtime.profiles import Smoothing
from facesynth.services.translator.core import Translator


def test_face_loss_ramps_linearly_to_neutral() -> None:
    translator = Translator(profile_of(feature_servo(), neutral_ramp_s=0.5))
    translator.step(features_at(0, {"jaw_open": 1.0}))
    out = positions_of(translator, [features_at(i, face=False) for i in range(1, 25)])
    expected_step = 500.0 / 0.5 * DT  # 500 µs to go in 0.5 s
    steps = np.diff([2000.0, *out])
    assert np.all(steps <= 0)
    assert np.all(np.abs(steps) <= expected_step + TOL)  # never a jump
    assert -steps[:14] == pytest.approx([expected_step] * 14)
    assert out[14] == pytest.approx(1500.0)  # there after 15 frames = 0.5 s
    assert out[-1] == 1500.0


@pytest.mark.parametrize(
    "lost",
    [
        {"face": False},
        {"ready": False},
        {"face": True, "named": {}},
    ],
    ids=["no-face", "neutral-not-ready", "no-features"],
)
def test_every_kind_of_no_tracking_ramps(lost: dict[str, Any]) -> None:
    translator = Translator(profile_of(feature_servo(), neutral_ramp_s=1.0))
    translator.step(features_at(0, {"jaw_open": -1.0}))
    named = lost.pop("named", None)
    out = translator.step(features_at(1, named, **lost))["s"]
    assert out == pytest.approx(1000.0 + 500.0 * DT)


def test_face_loss_uses_max_speed_when_set() -> None:
    translator = Translator(profile_of(feature_servo(max_speed=3000.0), neutral_ramp_s=5.0))
    translator.step(features_at(0, {"jaw_open": 1.0}))
    out = positions_of(translator, [features_at(i, face=False) for i in range(1, 8)])
    assert out[:4] == pytest.approx([1900.0, 1800.0, 1700.0, 1600.0])
    assert out[4:] == pytest.approx([1500.0] * 3)


def test_face_return_catches_up_then_tracks() -> None:
    translator = Translator(profile_of(feature_servo(), neutral_ramp_s=0.5))
    translator.step(features_at(0, face=False))
    catch_up = 1000.0 / 0.5 * DT  # the full travel per ramp time
    out = positions_of(translator, [features_at(i, {"jaw_open": 1.0}) for i in range(1, 10)])
    steps = np.diff([1500.0, *out])
    assert np.all(steps <= catch_up + TOL)
    assert out[:7] == pytest.approx([1500.0 + catch_up * (i + 1) for i in range(7)])
    assert out[7:] == pytest.approx([2000.0, 2000.0])
    # Caught up: tracking is unlimited again (this servo has no max_speed).
    assert translator.step(features_at(10, {"jaw_open": -1.0}))["s"] == pytest.approx(1000.0)


def test_neutral_ramp_zero_jumps_as_before() -> None:
    translator = Translator(profile_of(feature_servo(), neutral_ramp_s=0.0))
    translator.step(features_at(0, {"jaw_open": 1.0}))
    assert translator.step(features_at(1, face=False))["s"] == 1500.0
    assert translator.step(features_at(2, {"jaw_open": 1.0}))["s"] == 2000.0


@pytest.mark.parametrize(
    ("speed", "accel"),
    [(3000.0, 0.0), (2500.0, 30000.0), (0.0, 20000.0), (6000.0, 0.0)],
    ids=["speed", "speed-accel", "accel-only", "eyes"],
)
def test_tracking_is_rate_limited(speed: float, accel: float) -> None:
    translator = Translator(profile_of(feature_servo(max_speed=speed, max_accel=accel)))
    values = np.random.default_rng(3).uniform(-1.2, 1.2, 60).repeat(5)
    out = positions_of(
        translator, [features_at(i, {"jaw_open": float(v)}) for i, v in enumerate(values)]
    )
    steps = np.diff(out)
    if speed:
        assert np.abs(steps).max() <= speed * DT + TOL
    if accel:
        assert np.abs(np.diff(steps)).max() <= accel * DT * DT + TOL
    assert all(1000.0 <= v <= 2000.0 for v in out)
    held = positions_of(translator, [features_at(300 + i, {"jaw_open": 0.5}) for i in range(60)])
    assert held[-1] == pytest.approx(1750.0)  # reaches the target


def test_repeated_frame_time_holds_the_output() -> None:
    translator = Translator(
        profile_of(feature_servo(max_speed=3000.0), smoothing=Smoothing(min_cutoff=1.0, beta=0.5))
    )
    first = translator.step(features_at(0, {"jaw_open": 0.0}))["s"]
    second = translator.step(features_at(1, {"jaw_open": 1.0}))["s"]
    again = translator.step(features_at(1, {"jaw_open": -1.0}))["s"]  # same t_media_ns
    assert first == 1500.0 and 1500.0 < second == again


def test_looped_replay_time_going_back_does_not_jump() -> None:
    translator = Translator(profile_of(feature_servo(max_speed=3000.0)))
    positions_of(translator, [features_at(i, {"jaw_open": 1.0}) for i in range(20)])
    out = positions_of(
        translator, [features_at(i, {"jaw_open": -1.0}) for i in range(5)]
    )  # t restarts at 0
    assert out[0] == 2000.0  # held on the backward step
    assert np.abs(np.diff([2000.0, *out])).max() <= 3000.0 * DT + TOL
