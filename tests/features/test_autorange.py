"""services.features.autorange and FeatureProcessor(auto_range=True): neutral and ranges that
adapt to the stream, by media time."""

from __future__ import annotations

import math

import numpy as np
import pytest
from synthetic_face import IRIS, MESH, S, move, points_message

from facesynth.runtime.feature_names import BY_NAME
from facesynth.services.features.autorange import AutoRange, RollingNeutral, nan_median
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.expressions import BROW, LIP_CORNER

MS = 1_000_000


def _run(rolling: RollingNeutral, start_s: float, seconds: float, value: float, fps: int = 30):
    out = None
    for i in range(round(seconds * fps)):
        out = rolling.add(round((start_s + i / fps) * S), np.array([value]))
    return out


def test_rolling_neutral_ignores_an_expression_held_for_two_seconds() -> None:
    rolling = RollingNeutral(np.array([0.0]))
    _run(rolling, 0.0, 3.0, 0.0)
    assert _run(rolling, 3.0, 2.0, 1.0)[0] == 0.0
    assert _run(rolling, 5.0, 3.0, 0.0)[0] == 0.0


@pytest.mark.parametrize(
    ("held_s", "moved"),
    [(4.0, False), (4.9, False), (5.6, True), (8.0, True)],
    ids=["4s", "4.9s", "5.6s", "8s"],
)
def test_rolling_neutral_takes_a_new_resting_face_after_half_the_window(held_s, moved) -> None:
    rolling = RollingNeutral(np.array([0.0]))  # window 10 s, started full of the initial neutral
    value = _run(rolling, 0.0, held_s, 0.2)[0]
    assert value == (0.2 if moved else 0.0)


def test_rolling_neutral_ignores_nan_and_keeps_a_never_seen_value() -> None:
    rolling = RollingNeutral(np.array([0.0, math.nan]))
    for i in range(200):
        rolling.add(i * 100 * MS, np.array([math.nan, math.nan]))
    np.testing.assert_array_equal(rolling.neutral[:1], [0.0])
    assert math.isnan(rolling.neutral[1])
    for i in range(200, 205):
        rolling.add(i * 100 * MS, np.array([math.nan, 3.0]))
    assert rolling.neutral[1] == 3.0, "the first real samples of a missing value are its neutral"


def test_rolling_neutral_survives_media_time_going_back() -> None:
    rolling = RollingNeutral(np.array([0.0]))
    _run(rolling, 100.0, 6.0, 0.5)
    assert rolling.neutral[0] == 0.5
    _run(rolling, 0.0, 8.0, 0.0)  # the replay loops
    assert rolling.neutral[0] == 0.0


def test_rolling_neutral_is_deterministic() -> None:
    values = np.random.default_rng(1).normal(size=(300, 3))
    runs = []
    for _ in range(2):
        rolling = RollingNeutral(np.zeros(3))
        runs.append([rolling.add(i * 33 * MS, v).copy() for i, v in enumerate(values)])
    np.testing.assert_array_equal(runs[0], runs[1])


@pytest.mark.parametrize(
    "kwargs", [dict(window_s=0.0), dict(sample_s=0.0), dict(update_s=-1.0), dict(window_s=0.05)]
)
def test_rolling_neutral_bad_settings(kwargs) -> None:
    with pytest.raises(ValueError):
        RollingNeutral(np.zeros(1), **kwargs)


@pytest.mark.parametrize("rows", [1, 2, 3, 4, 7, 100])
def test_nan_median_matches_numpy(rows: int) -> None:
    rng = np.random.default_rng(rows)
    samples = rng.normal(size=(rows, 40))
    samples[rng.random(samples.shape) < 0.4] = np.nan
    fallback = np.full(40, 9.0)
    with (
        np.errstate(all="ignore"),
        pytest.warns(RuntimeWarning) if np.isnan(samples).all(axis=0).any() else _nothing(),
    ):
        expected = np.nanmedian(samples, axis=0)
    expected = np.where(np.isnan(expected), 9.0, expected)
    np.testing.assert_array_equal(nan_median(samples, fallback), expected)


class _nothing:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *args: object) -> None:
        return None


# --- AutoRange ------------------------------------------------------------------------------


def _auto(**kwargs) -> AutoRange:
    return AutoRange(["a", "b"], {"a": (-0.02, 0.08), "b": (-10.0, 10.0)}, **kwargs)


def test_range_widens_at_once_for_a_held_extreme_but_not_for_a_glitch() -> None:
    auto = _auto()
    auto.update(0, {"a": 0.0})
    auto.update(33 * MS, {"a": 0.5})  # one frame: a tracking glitch
    assert 0.079 < auto.update(66 * MS, {"a": 0.0})["a"][1] <= 0.08
    for i in range(3, 6):
        ranges = auto.update(i * 33 * MS, {"a": 0.12, "b": -14.0})
    assert ranges["a"][1] == pytest.approx(0.12)
    assert ranges["b"][0] == pytest.approx(-14.0)


def test_extremes_decay_toward_half_the_initial_range() -> None:
    auto = _auto(tau_s=30.0, floor_fraction=0.5)
    for i in range(3):
        auto.update(i * S // 30, {"a": 0.12, "b": 0.0})
    t0 = 2 * S // 30
    ranges = auto.update(t0 + 30 * S, {"a": 0.0, "b": 0.0})  # one time constant later
    assert ranges["a"][1] == pytest.approx(0.04 + 0.08 * math.exp(-1), rel=1e-9)
    # the low end has decayed since the start (t = 0), not only since the widening
    assert ranges["a"][0] == pytest.approx(-0.01 - 0.01 * math.exp(-(30 + t0 / S) / 30), rel=1e-9)
    ranges = auto.update(t0 + 3000 * S, {"a": 0.0, "b": 0.0})
    assert ranges["a"] == pytest.approx((-0.01, 0.04))  # never narrower than the floor
    assert ranges["b"] == pytest.approx((-5.0, 5.0))


def test_range_does_not_decay_when_time_stands_still_or_goes_back() -> None:
    auto = _auto()
    auto.update(10 * S, {})
    assert auto.update(10 * S, {}) == {"a": (-0.02, 0.08), "b": (-10.0, 10.0)}
    assert auto.update(5 * S, {}) == {"a": (-0.02, 0.08), "b": (-10.0, 10.0)}


@pytest.mark.parametrize(
    "kwargs",
    [dict(tau_s=0.0), dict(floor_fraction=0.0), dict(floor_fraction=1.5), dict(glitch_frames=0)],
)
def test_auto_range_bad_settings(kwargs) -> None:
    with pytest.raises(ValueError):
        _auto(**kwargs)


# --- FeatureProcessor(auto_range=True) -----------------------------------------------------

FPS = 10
RAISED = move(MESH, BROW["right"].mesh, dy=0.05)


def _feed(processor: FeatureProcessor, mesh: np.ndarray, start_s: float, seconds: float):
    outs = []
    for i in range(round(seconds * FPS)):
        t = round((start_s + i / FPS) * S)
        outs.append(processor.process(points_message(mesh, IRIS, t_media_ns=t)))
    return outs


def test_auto_neutral_keeps_a_two_second_expression_and_learns_a_new_resting_face() -> None:
    processor = FeatureProcessor(auto_range=True)
    _feed(processor, MESH, 0.0, 4.0)
    held = _feed(processor, RAISED, 4.0, 2.0)
    assert all(o.raw["brow_raise_inner_right"] == pytest.approx(0.05, abs=1e-9) for o in held)
    back = _feed(processor, MESH, 6.0, 2.0)
    assert max(abs(v) for v in back[-1].raw.values()) < 1e-9
    settled = _feed(processor, RAISED, 8.0, 8.0)
    assert settled[0].raw["brow_raise_inner_right"] == pytest.approx(0.05, abs=1e-9)
    assert abs(settled[-1].raw["brow_raise_inner_right"]) < 1e-9, "the new resting face"
    assert len(settled[-1].deltas) == 68 and max(map(abs, settled[-1].deltas)) < 1e-9
    assert max(map(abs, settled[-1].displacements)) < 1e-9


def test_fixed_mode_never_moves_the_neutral() -> None:
    processor = FeatureProcessor()
    _feed(processor, MESH, 0.0, 2.0)
    settled = _feed(processor, RAISED, 2.0, 15.0)
    assert settled[-1].raw["brow_raise_inner_right"] == pytest.approx(0.05, abs=1e-9)


def test_auto_range_scales_a_big_smile_to_one_then_decays() -> None:
    default_high = BY_NAME["lip_corner_pull_right"].default_max
    step = 0.14  # up and out: pull = 0.14 * sqrt(2) = 0.198, beyond 1.5 x the default range
    pull = step * math.sqrt(2)
    assert pull > 1.5 * default_high
    big = MESH
    for side, out in (("right", -1.0), ("left", 1.0)):
        big = move(big, LIP_CORNER[side].mesh, dx=out * step, dy=step)
    processor = FeatureProcessor(auto_range=True)
    _feed(processor, MESH, 0.0, 2.0)
    smile = _feed(processor, big, 2.0, 1.0)
    assert smile[0].named["lip_corner_pull_right"] == 1.5  # default range: clamped
    assert smile[-1].named["lip_corner_pull_right"] == pytest.approx(1.0)  # range widened
    _feed(processor, MESH, 3.0, 60.0)
    [again] = _feed(processor, big, 63.0, 0.1)
    _, high = processor.auto.range.ranges()["lip_corner_pull_right"]
    floor = default_high / 2  # ranges decay toward half the initial range, never narrower
    assert high == pytest.approx(floor + (pull - floor) * math.exp(-2), abs=2e-3), "2 tau later"
    assert again.named["lip_corner_pull_right"] == 1.5
