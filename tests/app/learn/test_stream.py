"""Streaming babbling (facesynth/app/learn/stream.py): seeded smooth trajectories, each frame's
face paired with the commands sent the head's lag earlier, stretches of stream held out whole
by the fit (facesynth/app/learn/dataset.py's ``with_stream``, fit.py's grouping)."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_babble import STILL, SyntheticHead, hardware, planned_babble, synthetic_babble

from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.fit import FitOptions, _choose_inputs, _split, fit_learned_profile
from facesynth.app.learn.plan import Plan
from facesynth.app.learn.stream import (
    BLOCK_S,
    DEFAULT_LAG_S,
    MAX_GAP_S,
    MAX_LAG_S,
    STREAM_KIND,
    StreamError,
    StreamOptions,
    Trajectory,
    lagged_commands,
    stream_blocks,
    stream_lag,
)
from facesynth.runtime.profiles import Profile

FRAME_S = 1 / 30
SERVOS = ("jaw", "lip", "brow")
INPUTS = ("mouth_open", "smile")
#: How fast each servo's pulse rises in :func:`ramp` (µs/s).
RATES = np.array([100.0, -50.0, 200.0])


def ns(seconds: np.ndarray | list[float]) -> np.ndarray:
    """Capture times in ns for times in seconds."""
    return np.round(np.asarray(seconds, dtype=np.float64) * 1e9).astype(np.int64)


def frames(seconds: float, start: float = 0.0) -> np.ndarray:
    """Frame times (s) at the camera's rate for ``seconds``."""
    return start + np.arange(round(seconds / FRAME_S)) * FRAME_S


def ramp(t_s: np.ndarray) -> np.ndarray:
    """Pulses that rise linearly in time, at a different rate per servo: (n, 3) for times (n,)
    or, per servo, for times (n, 3)."""
    t_s = np.asarray(t_s, dtype=np.float64)
    out: np.ndarray = 1500.0 + (t_s if t_s.ndim == 2 else t_s[:, None]) * RATES
    return out


def settled(n: int = 4) -> BabbleSet:
    """A few settled poses of three servos."""
    rng = np.random.default_rng(0)
    return BabbleSet(
        SERVOS, rng.uniform(1000, 2000, (n, 3)), INPUTS, rng.normal(size=(n, 2)), ("random",) * n
    )


def pulses(profile: Profile, u: np.ndarray) -> np.ndarray:
    """The pulses normalized commands ``u`` (n, S) of ``profile``'s servos stand for."""
    neutral = np.array([s.neutral_us for s in profile.servos])
    up = np.array([s.max_us - s.neutral_us for s in profile.servos])
    down = np.array([s.neutral_us - s.min_us for s in profile.servos])
    out: np.ndarray = neutral + np.where(u >= 0, u * up, u * down)
    return out


def with_head_stream(babble: BabbleSet, seconds: float, lag: float = 0.1) -> BabbleSet:
    """``babble`` and a stream of the synthetic head at 10 frames a second, paused for 1 s
    halfway, each face the one the commands ``lag`` earlier make."""
    head, profile, trajectory = SyntheticHead(seed=3, noise=0.005), hardware(), Trajectory(16, 7)
    t = np.arange(0.0, seconds, 0.1)
    t = np.where(t >= seconds / 2, t + 1.0, t)
    u_now = np.array([trajectory.at(s) for s in t])
    u_seen = np.array([trajectory.at(max(s - lag, 0.0)) for s in t])
    noise = np.random.default_rng(9).normal(0.0, 0.02, (len(t), len(STILL)))
    faces = np.concatenate([head.features(u_seen), noise], axis=1)
    return babble.with_stream(ns(t), pulses(profile, u_now), faces, lag)


def test_a_trajectory_is_seeded() -> None:
    """The same seed gives the same commands (a resumed run goes on with them), another seed
    other commands."""
    times = frames(3.0)
    one = np.array([Trajectory(5, 42).at(t) for t in times])
    again = np.array([Trajectory(5, 42).at(t) for t in times])
    other = np.array([Trajectory(5, 43).at(t) for t in times])
    assert one.shape == (len(times), 5)
    np.testing.assert_array_equal(one, again)
    assert np.abs(one - other).max() > 0.1


def test_a_trajectory_stays_in_range_and_moves_smoothly() -> None:
    """Commands in [-1, 1], and between two frames they change no more than the waves at the
    highest frequency can (the clipping only slows them)."""
    for options in (StreamOptions(), StreamOptions(max_hz=3.0, waves=8, amplitude=1.0)):
        u = np.array([Trajectory(16, 1, options).at(t) for t in frames(20.0)])
        assert np.all(np.abs(u) <= 1.0) and u.std() > 0.1
        bound = options.waves * options.amplitude * 2 * np.pi * options.max_hz * FRAME_S
        assert np.abs(np.diff(u, axis=0)).max() <= bound + 1e-9


def test_a_trajectorys_frequencies_are_within_its_band() -> None:
    """A band of one frequency f repeats every 1/f s and is negated after half of it; a slow
    band moves far less in 0.1 s than a fast one."""
    single = Trajectory(6, 5, StreamOptions(min_hz=0.5, max_hz=0.5, amplitude=0.3))
    for t in (0.0, 0.37, 5.1):
        np.testing.assert_allclose(single.at(t + 2.0), single.at(t), atol=1e-9)
        np.testing.assert_allclose(single.at(t + 1.0), -single.at(t), atol=1e-9)

    def moved(options: StreamOptions) -> float:
        u = np.array([Trajectory(16, 2, options).at(t) for t in np.arange(0, 30, 0.1)])
        return float(np.abs(np.diff(u, axis=0)).mean())

    slow = moved(StreamOptions(min_hz=0.05, max_hz=0.1))
    assert slow < 0.2 * moved(StreamOptions(min_hz=1.5, max_hz=2.0))
    assert slow <= 4 * 0.4 * 2 * np.pi * 0.1 * 0.1


@pytest.mark.parametrize(
    "bad",
    [
        {"min_hz": 0.0},
        {"min_hz": 2.0, "max_hz": 1.0},
        {"max_hz": 11.0},
        {"waves": 0},
        {"waves": 17},
        {"amplitude": 0.0},
        {"amplitude": 1.5},
        {"min_hz": float("nan")},
        {"max_hz": float("nan")},
        {"amplitude": float("nan")},
    ],
)
def test_unusable_stream_options_are_refused(bad: dict[str, float]) -> None:
    with pytest.raises(StreamError):
        StreamOptions(**bad)  # type: ignore[arg-type]


def test_commands_are_paired_at_each_servos_lag() -> None:
    """A ramp paired at lag L is its value at t - L (interpolated exactly between frames); lag 0
    is the commands themselves; each servo at its own lag; NaN before the first frame."""
    t = frames(2.0)
    lags = np.array([0.05, 0.0, 0.21])
    paired = lagged_commands(ns(t), ramp(t), lags)
    for servo, lag in enumerate(lags):
        known = t - lag >= 0
        np.testing.assert_allclose(paired[known, servo], ramp(t - lag)[known, servo], atol=1e-6)
        assert np.all(np.isnan(paired[~known, servo]))
    np.testing.assert_array_equal(paired[:, 1], ramp(t)[:, 1])
    assert np.isnan(paired[:, 2]).sum() == 7 and np.isnan(paired[:, 0]).sum() == 2


def test_no_command_is_interpolated_across_a_gap() -> None:
    """Frames 1 s apart (the face was lost): an instant within the gap has no command, one
    after it does."""
    t = np.concatenate([frames(1.0), frames(1.0, start=2.0)])
    assert np.diff(t).max() > MAX_GAP_S
    paired = lagged_commands(ns(t), ramp(t), np.full(3, 0.11))
    lost = (t > 1.5) & (t - 0.11 < 2.0)
    assert lost.sum() == 4 and np.all(np.isnan(paired[lost]))
    fine = (t >= 0.11) & ~lost
    np.testing.assert_allclose(paired[fine], ramp(t - 0.11)[fine], atol=1e-6)


def test_lag_zero_is_the_commands_even_at_a_gap() -> None:
    """Lag 0 wants each frame's own instant, which needs no interpolation across the gap."""
    t = np.concatenate([frames(1.0), frames(1.0, start=2.0)])
    np.testing.assert_array_equal(lagged_commands(ns(t), ramp(t), np.zeros(3)), ramp(t))


def test_malformed_streams_are_refused_and_an_empty_one_pairs_nothing() -> None:
    t = frames(1.0)
    with pytest.raises(StreamError, match="not negative"):
        lagged_commands(ns(t), ramp(t), np.array([0.1, -0.05, 0.0]))
    with pytest.raises(StreamError, match="lasts some time"):
        stream_blocks(ns(t), 0.0)
    with pytest.raises(StreamError, match="time order"):
        lagged_commands(ns(t[::-1]), ramp(t), np.zeros(3))
    with pytest.raises(StreamError, match="do not match"):
        lagged_commands(ns(t), ramp(t)[:-1], np.zeros(3))
    with pytest.raises(StreamError, match="do not match"):
        lagged_commands(ns(t), ramp(t), np.zeros(2))
    assert lagged_commands(ns([]), np.zeros((0, 3)), np.zeros(3)).shape == (0, 3)


def test_stream_blocks_are_consecutive_stretches_restarted_by_a_gap() -> None:
    """Stretches of BLOCK_S from 0; a gap starts a new one even halfway through a stretch."""
    t = frames(5.0)
    np.testing.assert_array_equal(stream_blocks(ns(t)), np.floor(t / BLOCK_S + 1e-9))
    t = np.concatenate([frames(3.0), frames(3.0, start=4.0)])  # the gap at 3 s, mid-stretch
    blocks = stream_blocks(ns(t))
    expected = np.where(t < 3.0, np.floor(t / BLOCK_S + 1e-9), 2 + (t >= 6.0 - 1e-9))
    np.testing.assert_array_equal(blocks, expected)
    assert stream_blocks(ns([])).shape == (0,)


def test_with_stream_appends_frames_paired_at_the_lag() -> None:
    """Stream rows after the settled ones, each with the commands of 0.05 s earlier; the first
    frames (no command that early) left out; settled rows stretch -1, stream rows from 0."""
    base, t = settled(), frames(4.0)
    faces = np.column_stack([t, -t])
    out = base.with_stream(ns(t), ramp(t), faces, 0.05)
    assert len(out) == len(base) + len(t) - 2
    assert out.kinds == base.kinds + (STREAM_KIND,) * (len(t) - 2)
    np.testing.assert_array_equal(out.commands[:4], base.commands)
    np.testing.assert_array_equal(out.faces[:4], base.faces)
    np.testing.assert_allclose(out.commands[4:], ramp(t[2:] - 0.05), atol=1e-6)
    np.testing.assert_array_equal(out.faces[4:], faces[2:])
    np.testing.assert_array_equal(base.stretches(), [-1] * 4)
    stretches = out.stretches()
    np.testing.assert_array_equal(stretches[:4], [-1] * 4)
    assert stretches[4] == 0 and set(stretches[4:]) == {0, 1} and np.all(np.diff(stretches) >= 0)


def test_a_stream_is_paired_at_the_median_of_the_lags_measured() -> None:
    """Lags measured per servo: every servo paired at their median (a servo not of the set
    left out), never below 0 nor above MAX_LAG_S; none measured: the default."""
    assert stream_lag({"jaw": 0.05, "brow": 0.25, "lip": -0.04, "ear": 9.0}, SERVOS) == 0.05
    assert stream_lag({"jaw": -0.06, "lip": -0.03}, SERVOS) == 0.0
    assert stream_lag({"jaw": 0.5, "brow": 0.4}, SERVOS) == MAX_LAG_S
    assert stream_lag({"ear": 0.05}, SERVOS) == DEFAULT_LAG_S
    base, t = settled(), frames(3.0)
    faces = np.zeros((len(t), 2))
    out = base.with_stream(ns(t), ramp(t), faces, {"jaw": 0.05, "brow": 0.25, "lip": 0.15})
    kept = t[t >= 0.15 - 1e-9]
    assert len(out) == len(base) + len(kept)
    np.testing.assert_allclose(out.commands[4:], ramp(kept - 0.15), atol=1e-6)
    default = base.with_stream(ns(t), ramp(t), faces, {})
    assert len(default) == len(base) + int((t >= DEFAULT_LAG_S - 1e-9).sum())
    np.testing.assert_allclose(default.commands[-1], ramp(t[-1:] - DEFAULT_LAG_S)[0])


def test_a_second_stream_continues_the_stretches() -> None:
    base, t = settled(), frames(5.0)
    faces = np.zeros((len(t), 2))
    once = base.with_stream(ns(t), ramp(t), faces)
    twice = once.with_stream(ns(t), ramp(t), faces)
    first, second = twice.stretches()[4 : len(once)], twice.stretches()[len(once) :]
    assert set(first) == {0, 1, 2} and set(second) == {3, 4, 5}
    np.testing.assert_array_equal(twice.stretches()[: len(once)], once.stretches())


def test_streams_that_do_not_fit_the_set_are_refused() -> None:
    base, t = settled(), frames(1.0)
    with pytest.raises(ValueError, match="stream faces"):
        base.with_stream(ns(t), ramp(t), np.zeros((len(t), 3)))
    with pytest.raises(ValueError, match="stream faces"):
        base.with_stream(ns(t), ramp(t), np.zeros((len(t) - 1, 2)))
    with pytest.raises(ValueError, match="blocks shape"):
        BabbleSet(base.servos, base.commands, INPUTS, base.faces, base.kinds, blocks=np.zeros(3))


def test_the_fit_holds_out_whole_stretches_of_stream() -> None:
    """Each stretch is one group (train or held out whole), stretches differ, and no stream
    group is a settled pose's."""
    babble = with_head_stream(synthetic_babble(300), 120.0)
    stretches = babble.stretches()
    assert (stretches >= 0).sum() > 1000 and stretches.max() == 59  # 30 each side of the pause
    data = _choose_inputs(babble, babble.normalized(hardware()), FitOptions())
    train, held_out = _split(data.groups, FitOptions())
    kept = stretches[np.all(np.isfinite(babble.faces[:, : -len(STILL)]), axis=1)]
    assert len(kept) == len(data.groups)
    streamed = kept >= 0
    for stretch in np.unique(kept[streamed]):
        rows = kept == stretch
        assert len(np.unique(data.groups[rows])) == 1
        assert np.all(train[rows]) or np.all(held_out[rows])
    stream_groups = data.groups[streamed]
    assert len(np.unique(stream_groups)) == len(np.unique(kept[streamed]))
    assert not set(stream_groups) & set(data.groups[~streamed])
    out_stretches = np.unique(kept[streamed & held_out])
    assert 0 < len(out_stretches) < len(np.unique(kept[streamed]))


def test_a_fit_on_sweeps_and_a_stream_reports() -> None:
    """The settled sweeps and two minutes of stream (~1,200 frames) fit in a few seconds."""
    babble = with_head_stream(planned_babble(Plan(16).sweep_poses), 120.0)
    fitted = fit_learned_profile(babble, hardware(), FitOptions(candidates=("poly_ridge",)))
    learned = fitted.learned
    assert learned is not None
    report = learned.report
    assert report.samples + report.dropped == len(babble)
    assert 0.1 * len(babble) < report.held_out < 0.4 * len(babble)
    assert set(report.servo_error) == set(learned.outputs) and len(learned.outputs) >= 10
    assert max(report.servo_error.values()) < 0.1, report.servo_error
