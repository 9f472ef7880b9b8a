"""services.translator.core with One Euro smoothing: less jitter, range units, overrides."""

from __future__ import annotations

import numpy as np
import pytest
from translator_fixtures import feature_servo, features_at, jaw_deltas, positions_of, profile_of

from facesynth.runtime.profiles import Smoothing, SmoothingOverride
from facesynth.services.translator.core import Translator

SMOOTH = Smoothing(min_cutoff=0.5, beta=1.0, d_cutoff=1.0)


def _noisy(n: int = 300, sigma: float = 0.1) -> np.ndarray:
    return np.random.default_rng(11).normal(0.2, sigma, n)


def test_smoothing_reduces_jitter() -> None:
    values = _noisy()
    frames = [features_at(i, {"jaw_open": float(v)}) for i, v in enumerate(values)]
    raw = positions_of(Translator(profile_of(feature_servo())), frames)
    smooth = positions_of(Translator(profile_of(feature_servo(), smoothing=SMOOTH)), frames)
    assert np.std(smooth[30:]) < 0.5 * np.std(raw[30:])
    assert np.mean(smooth[30:]) == pytest.approx(np.mean(raw[30:]), abs=10.0)


@pytest.mark.parametrize(
    "smoothing",
    [None, Smoothing(enabled=False, min_cutoff=0.1)],
    ids=["absent", "disabled"],
)
def test_no_smoothing_is_the_plain_mapping(smoothing: Smoothing | None) -> None:
    values = _noisy(50)
    translator = Translator(profile_of(feature_servo(), smoothing=smoothing))
    out = positions_of(
        translator, [features_at(i, {"jaw_open": float(v)}) for i, v in enumerate(values)]
    )
    expected = [translator.positions(np.zeros(68), {"jaw_open": float(v)})["s"] for v in values]
    assert out == pytest.approx(expected)


def test_points_are_filtered_in_range_units() -> None:
    # The same movement as a point group (half range 0.1 IOD) and as a scaled feature.
    values = _noisy(100)
    profile = profile_of(
        feature_servo("named", 0),
        feature_servo("group", 1, points=[56, 57, 58], face_min=-0.1, face_max=0.1),
        smoothing=SMOOTH,
    )
    translator = Translator(profile)
    frames = [
        features_at(i, {"jaw_open": float(v)}, jaw_deltas(0.1 * v)) for i, v in enumerate(values)
    ]
    out = [translator.step(frame) for frame in frames]
    assert [o["group"] for o in out] == pytest.approx([o["named"] for o in out])


def test_per_servo_override_and_shared_filters() -> None:
    profile = profile_of(
        feature_servo("a", 0),
        feature_servo("b", 1),
        feature_servo("c", 2, smoothing=SmoothingOverride(min_cutoff=5.0)),
        feature_servo("d", 3, smoothing=SmoothingOverride(enabled=False)),
        smoothing=SMOOTH,
    )
    values = _noisy(100)
    translator = Translator(profile)
    out = [translator.step(features_at(i, {"jaw_open": float(v)})) for i, v in enumerate(values)]
    a, b, c, d = ([o[n] for o in out] for n in "abcd")
    assert a == b  # one signal, one filter, one output
    assert np.std(a[30:]) < np.std(c[30:]) < np.std(d[30:])
    assert d == pytest.approx([1500.0 + 500.0 * v for v in values])
    assert profile.smoothing_for(profile.servos[2]) == Smoothing(
        min_cutoff=5.0, beta=1.0, d_cutoff=1.0
    )
    assert profile.smoothing_for(profile.servos[3]) is None


def test_override_without_a_profile_table() -> None:
    profile = profile_of(feature_servo(smoothing=SmoothingOverride(beta=2.0)))
    assert profile.smoothing_for(profile.servos[0]) == Smoothing(beta=2.0)
