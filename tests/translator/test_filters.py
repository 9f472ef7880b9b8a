"""facesynth.services.translator.filters: the One Euro filter and the speed/acceleration limiter."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest

from facesynth.services.translator.filters import (
    OneEuroFilter,
    RateLimiter,
    braking_speed,
    limit_step,
    smoothing_factor,
)

FPS = 30.0
FRAME_NS = round(1e9 / FPS)


def _run(flt: OneEuroFilter, values: list[float] | np.ndarray, frame_ns: int = FRAME_NS) -> list:
    return [flt(float(v), i * frame_ns) for i, v in enumerate(values)]


def _frames_to(outputs: list[float], level: float) -> int:
    return next(i for i, v in enumerate(outputs) if v >= level)


# --- One Euro -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("cutoff", "dt", "expected"),
    [
        (1.0, 1 / 30, 1 / (1 + 30 / (2 * math.pi))),
        (10.0, 0.01, 1 / (1 + 1 / (2 * math.pi * 10 * 0.01))),
        (1.0, 1e9, 1.0),
    ],
    ids=["1hz-30fps", "10hz-100fps", "huge-dt"],
)
def test_smoothing_factor(cutoff: float, dt: float, expected: float) -> None:
    assert smoothing_factor(cutoff, dt) == pytest.approx(expected)


@pytest.mark.parametrize(
    ("params", "value"),
    [
        ((1.0, 0.0, 1.0), 0.0),
        ((0.5, 1.0, 1.0), 0.7),
        ((2.0, 10.0, 0.5), -1.3),
        ((1.0, 5.0, 1.0), 1e3),
    ],
    ids=["zero", "paper16", "fast", "large"],
)
def test_constant_input_gives_constant_output(
    params: tuple[float, float, float], value: float
) -> None:
    outputs = _run(OneEuroFilter(*params), [value] * 100)
    assert outputs == [value] * 100


def test_first_sample_passes_through() -> None:
    assert OneEuroFilter(1.0, 0.0, 1.0)(0.42, 123) == 0.42


@pytest.mark.parametrize("beta", [0.0, 0.3, 1.0, 5.0], ids=["b0", "b0.3", "b1", "b5"])
def test_step_response_is_monotone_and_converges(beta: float) -> None:
    outputs = _run(OneEuroFilter(1.0, beta, 1.0), [0.0] * 5 + [1.0] * 300)
    assert all(b >= a for a, b in itertools.pairwise(outputs))
    assert all(0.0 <= v <= 1.0 for v in outputs)
    assert outputs[5] > 0.0  # it starts moving on the step's frame
    assert outputs[-1] == pytest.approx(1.0, abs=1e-3)


def test_higher_beta_gives_less_lag() -> None:
    step = [0.0] * 5 + [1.0] * 120
    lags = [_frames_to(_run(OneEuroFilter(0.5, beta, 1.0), step), 0.9) for beta in (0.0, 1.0, 5.0)]
    assert lags[0] > lags[1] > lags[2]


def test_lower_min_cutoff_gives_less_jitter() -> None:
    noise = np.random.default_rng(1).normal(0.0, 0.05, 600)
    stds = [float(np.std(_run(OneEuroFilter(mc, 0.0, 1.0), noise)[30:])) for mc in (0.5, 2.0)]
    assert stds[0] < stds[1] < float(np.std(noise[30:]))


def test_same_time_returns_the_previous_output() -> None:
    flt = OneEuroFilter(1.0, 0.5, 1.0)
    reference = OneEuroFilter(1.0, 0.5, 1.0)
    for i, v in enumerate([0.0, 0.5, 0.2]):
        assert flt(v, i * FRAME_NS) == reference(v, i * FRAME_NS)
    held = flt.value
    assert flt(9.0, 2 * FRAME_NS) == held  # a repeated frame: no update, no jump
    assert flt(0.3, 3 * FRAME_NS) == reference(0.3, 3 * FRAME_NS)  # the repeat left no trace


@pytest.mark.parametrize(
    ("next_t_ns", "passes_through"),
    [
        (FRAME_NS, True),  # time went back (a looped replay)
        (2 * FRAME_NS + 600_000_000, True),  # a gap longer than 0.5 s
        (2 * FRAME_NS + 400_000_000, False),  # a shorter gap: still filtered
        (3 * FRAME_NS, False),
    ],
    ids=["backwards", "long-gap", "short-gap", "next-frame"],
)
def test_time_going_back_or_long_gaps_restart(next_t_ns: int, passes_through: bool) -> None:
    flt = OneEuroFilter(1.0, 0.0, 1.0)
    flt(0.0, 0)
    flt(0.0, FRAME_NS)
    flt(0.0, 2 * FRAME_NS)
    out = flt(1.0, next_t_ns)
    assert (out == 1.0) is passes_through
    assert 0.0 < out <= 1.0


def test_reset_forgets() -> None:
    flt = OneEuroFilter(1.0, 0.0, 1.0)
    _run(flt, [0.0, 0.0, 0.0])
    flt.reset()
    assert flt.value is None
    assert flt(0.8, 0) == 0.8


@pytest.mark.parametrize(
    "params",
    [(0.0, 0.0, 1.0), (1.0, -0.1, 1.0), (1.0, 0.0, 0.0), (-1.0, 0.0, 1.0)],
    ids=["min-cutoff-0", "beta-negative", "d-cutoff-0", "min-cutoff-negative"],
)
def test_invalid_parameters(params: tuple[float, float, float]) -> None:
    with pytest.raises(ValueError, match="One Euro filter needs"):
        OneEuroFilter(*params)


# --- limit_step -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("position", "target", "dt", "speed", "expected"),
    [
        (1500.0, 2000.0, 0.1, 1000.0, 1600.0),
        (1500.0, 1000.0, 0.1, 1000.0, 1400.0),
        (1500.0, 1550.0, 0.1, 1000.0, 1550.0),  # reachable: exactly there, no overshoot
        (1500.0, 2000.0, 0.1, 0.0, 2000.0),  # unlimited
        (1500.0, 2000.0, 0.0, 1000.0, 1500.0),  # no time: no move
        (1500.0, 2000.0, -0.1, 1000.0, 1500.0),
        (1500.0, 1500.0, 0.1, 1000.0, 1500.0),
    ],
    ids=["up", "down", "reach", "unlimited", "dt-0", "dt-negative", "at-target"],
)
def test_speed_limit(
    position: float, target: float, dt: float, speed: float, expected: float
) -> None:
    assert limit_step(position, 0.0, target, dt, speed)[0] == pytest.approx(expected)


@pytest.mark.parametrize(
    ("speed", "accel", "distance"),
    [
        (3000.0, 0.0, 500.0),
        (3000.0, 30000.0, 500.0),
        (0.0, 20000.0, 1000.0),
        (6000.0, 50000.0, -800.0),
        (2000.0, 5000.0, 3.0),
    ],
    ids=["speed", "speed-accel", "accel-only", "fast-down", "tiny-move"],
)
def test_limits_are_respected_and_the_target_is_reached(
    speed: float, accel: float, distance: float
) -> None:
    dt = 1 / FPS
    position, velocity, target = 1500.0, 0.0, 1500.0 + distance
    positions = [position]
    velocities = [velocity]
    for _ in range(300):
        position, velocity = limit_step(position, velocity, target, dt, speed, accel)
        positions.append(position)
        velocities.append(velocity)
    steps = np.diff(positions)
    if speed:
        assert np.all(np.abs(steps) <= speed * dt + 1e-6)
    if accel:
        assert np.all(np.abs(np.diff(velocities)) <= accel * dt + 1e-6)
    assert positions[-1] == pytest.approx(target, abs=1e-3)
    # Never past the target (the limiter brakes in time).
    assert all((target - p) * distance >= -1e-6 for p in positions)


def test_acceleration_bound_slows_the_start() -> None:
    dt = 1 / FPS
    free = limit_step(1500.0, 0.0, 2000.0, dt, 3000.0)[0]
    smooth = limit_step(1500.0, 0.0, 2000.0, dt, 3000.0, 30000.0)[0]
    assert free == pytest.approx(1600.0)
    assert smooth == pytest.approx(1500.0 + 1000.0 * dt)  # v = a·dt after one step


@pytest.mark.parametrize(
    ("distance", "accel", "dt"),
    [
        (0.0, 1000.0, 0.1),
        (100.0, 1000.0, 0.1),
        (5.0, 3e4, 1 / 30),
        # A bound that passes validation but whose speed change underflows (found by the fuzz
        # suite through a learned profile's hardware servos: OverflowError before).
        (500.0, 5e-324, 1 / 30),
        (500.0, 1e-310, 0.001),
    ],
)
def test_braking_speed_stops_within_the_distance(distance: float, accel: float, dt: float) -> None:
    speed = braking_speed(distance, accel, dt)
    covered, v = 0.0, speed
    while v > 0:
        covered += v * dt
        v -= accel * dt
    assert covered <= distance + 1e-9


@pytest.mark.timeout(10)
@pytest.mark.parametrize(
    ("distance", "accel", "dt"),
    [
        # So many steps of speed change that k(k+1)/2 is past the floats' whole numbers: the
        # exact search never ended (found by the fuzz suite through a learned profile).
        (1.0, 1e-200, 0.03),
        (1e10, 1.0, 0.001),
        (500.0, 1e-20, 1 / 30),
        (1e300, 1e-10, 0.03),
    ],
)
def test_braking_speed_of_very_many_steps_is_found_and_stops_within_the_distance(
    distance: float, accel: float, dt: float
) -> None:
    speed = braking_speed(distance, accel, dt)
    assert 0.0 <= speed < math.inf
    v, step, t = Fraction(speed), Fraction(accel) * Fraction(dt), Fraction(dt)
    steps = math.ceil(v / step)  # the positive speeds v, v - step, …
    covered = t * (steps * v - step * steps * (steps - 1) / 2)
    assert covered <= Fraction(distance) * (1 + Fraction(1, 10**9))
    if distance < 1e300:  # and it is no needless crawl: within a step of the exact bound
        assert speed >= math.sqrt(2.0 * distance * accel) - 2 * accel * dt


# --- RateLimiter --------------------------------------------------------------------------------


def test_rate_limiter_first_target_passes_then_limits() -> None:
    limiter = RateLimiter(max_speed=3000.0)
    assert limiter(2000.0, 0) == 2000.0
    assert limiter(1000.0, FRAME_NS) == pytest.approx(1900.0)
    assert limiter(1000.0, FRAME_NS) == pytest.approx(1900.0)  # repeated frame: hold
    assert limiter(1000.0, 0) == pytest.approx(1900.0)  # time went back: hold, restart clock
    assert limiter(1000.0, FRAME_NS) == pytest.approx(1800.0)
    assert limiter(1000.0, 2 * FRAME_NS, max_speed=6000.0) == pytest.approx(1600.0)


def test_rate_limiter_caps_long_steps() -> None:
    limiter = RateLimiter(max_speed=1000.0, max_dt_s=0.25)
    limiter(1500.0, 0)
    assert limiter(2000.0, 10 * 10**9) == pytest.approx(1750.0)  # 10 s counts as 0.25 s


def test_rate_limiter_reset_at_a_position() -> None:
    limiter = RateLimiter(max_speed=1000.0)
    limiter.reset(1500.0)
    assert limiter(2000.0, 5 * FRAME_NS) == 1500.0  # the clock starts
    assert limiter(2000.0, 8 * FRAME_NS) == pytest.approx(1600.0)
