"""Retargeting into what the robot can reach (services.translator.retarget): targets clipped
into the babbling's box, regions scaled as one, features the robot cannot show left out, and
each feature weighted by how much the performer moves it (time as data)."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from facesynth.runtime.profiles.learned import Retarget
from facesynth.runtime.profiles.learned_retarget import fitted_retarget
from facesynth.services.translator.retarget import MovementWeights, Retargeter, region, showable

S = 1_000_000_000  # ns a second


def retargeter(
    inputs: list[str],
    low: list[float],
    high: list[float],
    noise: list[float] | None = None,
    **options: float,
) -> Retargeter:
    n = len(inputs)
    return Retargeter(
        inputs,
        np.array(low),
        np.array(high),
        np.full(n, 0.01),
        None if noise is None else np.array(noise),
        Retarget(**options),
    )


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("head_yaw", "head"),
        ("gaze_left_x", "gaze"),
        ("eyeLookInRight", "gaze"),
        ("eye_open_right", "eyes"),
        ("eyeBlinkLeft", "eyes"),
        ("lid_tighten_left", "eyes"),
        ("brow_lower_left", "brows"),
        ("browInnerUp", "brows"),
        ("cheek_raise_right", "cheeks"),
        ("noseSneerLeft", "cheeks"),
        ("jaw_open", "mouth"),
        ("lips_part", "mouth"),
        ("mouthSmileLeft", "mouth"),
        ("tongueOut", "other"),
    ],
)
def test_every_feature_has_its_face_region(name: str, expected: str) -> None:
    assert region(name) == expected


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (0.05, 0.045),  # within the robot's reach: 0.9 of the performer's change
        (0.0, 0.0),
        (-0.02, -0.018),
        (0.5, 0.1),  # far beyond: clipped into the box (reach 0.1 above neutral)
        (-0.5, -0.05),  # ... and below (-0.05)
    ],
)
def test_a_feature_alone_is_0_9_of_the_change_clipped_into_the_box(
    change: float, expected: float
) -> None:
    target = retargeter(["jaw_open"], [-0.05], [0.1]).targets(np.array([change]))
    assert target == pytest.approx([expected])


def test_a_new_fit_asks_for_more_than_her_change_within_the_robots_reach() -> None:
    # The plan, T's smoothing and the head's lag keep about three quarters of the target's
    # amplitude: a new fit asks for 1.1 of her change, still clipped into the box; a file
    # fitted before carries Emo's 0.9 and keeps it
    new = retargeter(["jaw_open"], [-0.05], [0.1], **msgspec.structs.asdict(fitted_retarget()))
    assert new.targets(np.array([0.05])) == pytest.approx([0.055])
    assert new.targets(np.array([-0.02])) == pytest.approx([-0.022])
    assert new.targets(np.array([0.095])) == pytest.approx([0.1])  # 0.1045: the box's edge
    assert new.targets(np.array([-0.5])) == pytest.approx([-0.05])
    old = retargeter(["jaw_open"], [-0.05], [0.1], gain=0.9)
    assert old.targets(np.array([0.05])) == pytest.approx([0.045])


def test_by_default_each_feature_is_clipped_on_its_own() -> None:
    brows = ["brow_raise_inner_right", "brow_raise_inner_left", "jaw_open"]
    model = retargeter(brows, [-0.05] * 3, [0.1, 0.1, 0.2])
    target = model.targets(np.array([0.125, 0.0625, 0.1]))
    assert target == pytest.approx([0.1, 0.05625, 0.09])


def test_a_feature_she_moves_beyond_the_robots_reach_is_scaled_into_it() -> None:
    model = retargeter(["jaw_open", "lips_part"], [-0.05, -0.05], [0.1, 0.3], extent=2.5)
    for frame in range(300):  # ten seconds: her jaw and lips at an RMS of 0.1
        model.weights.update(np.array([0.1, -0.1]) * (-1) ** frame, frame * S // 30)
    assert model.weights.rms() == pytest.approx([0.1, 0.1])
    # the jaw's extent (2.5 RMS, 0.25) is beyond its reach (0.1): 0.9 of her change, times
    # 0.1 / 0.25; the lips' (0.25) is within theirs above (0.3): 0.9 of it, as it is
    assert model.targets(np.array([0.1, 0.1])) == pytest.approx([0.036, 0.09])
    # below neutral both reach 0.05 only: scaled by 0.05 / 0.25, then within the box
    assert model.targets(np.array([-0.1, -0.25])) == pytest.approx([-0.018, -0.045])
    # with extent 0 only the clip is left (Emo's retargeting as it is)
    clip = retargeter(["jaw_open"], [-0.05], [0.1], extent=0.0)
    clip.weights.update(np.array([0.1]), 0)
    assert clip.targets(np.array([0.1])) == pytest.approx([0.09])


def test_by_default_a_change_whose_95th_percentile_is_within_reach_is_not_scaled_down() -> None:
    # Her jaw at an RMS of 0.04: were it normally distributed, 95 % of its frames within
    # 0.078 of her neutral, 0.9 of which (0.07) the robot reaches (0.08). Her extent is taken
    # at about that 95th percentile (1.9 RMS, 0.076), so her change is only clipped, not
    # scaled (2.5 RMS, 0.1, scaled it by 0.8).
    model = retargeter(["jaw_open"], [-0.08], [0.08])
    for frame in range(300):
        model.weights.update(np.array([0.04]) * (-1) ** frame, frame * S // 30)
    assert model.weights.rms() == pytest.approx([0.04])
    assert model.targets(np.array([0.05])) == pytest.approx([0.045])
    assert model.targets(np.array([-0.078])) == pytest.approx([-0.9 * 0.078])


def test_a_region_shrinks_as_one_before_its_features_are_clipped() -> None:
    brows = ["brow_raise_inner_right", "brow_raise_inner_left", "jaw_open"]
    model = retargeter(brows, [-0.05] * 3, [0.1, 0.1, 0.2], region_floor=0.5)
    # the right brow wants 0.9 * 0.125 = 0.1125 > 0.1: both brows shrink by 0.1 / 0.1125,
    # so the left keeps its share of the right's; the jaw (another region) is untouched
    target = model.targets(np.array([0.125, 0.0625, 0.1]))
    assert target == pytest.approx([0.1, 0.05, 0.09])
    # far beyond the reach: the region shrinks to region_floor at most, then clips
    target = model.targets(np.array([1.0, 0.1, 0.0]))
    assert target == pytest.approx([0.1, 0.09 * 0.5, 0.0])


def test_a_side_the_robot_hardly_reaches_is_clipped_without_shrinking_its_region() -> None:
    # lips_part reaches 0.001 below neutral (a one-way actuator): asking for less than that
    # must not flatten the jaw beside it
    model = retargeter(["jaw_open", "lips_part"], [-0.05, -0.001], [0.2, 0.25], region_floor=0.5)
    assert model.targets(np.array([0.1, -0.05])) == pytest.approx([0.09, -0.001])


def test_features_the_robot_cannot_show_are_left_out() -> None:
    inputs = ["eyeBlinkLeft", "head_yaw", "jaw_open"]
    # the commands explained none of the blink and the yaw while babbling: not shown
    model = retargeter(inputs, [-0.02, -1.0, -0.05], [0.02, 1.0, 0.2], noise=[0.01, 0.012, 0.002])
    assert model.shown.tolist() == [False, False, True]
    target = model.targets(np.array([0.8, 20.0, 0.1]))
    assert target == pytest.approx([0.0, 0.0, 0.09])  # the robot's neutral where not shown
    weights = model.weights.update(np.array([0.8, 20.0, 0.1]), 0)
    assert weights.tolist() == [0.0, 0.0, 1.0]  # and no weight in the plan


def test_showable_reads_the_noise_against_the_robots_spread() -> None:
    scale = np.array([0.1, 0.1, 0.1])
    assert showable(scale, None, 0.9).tolist() == [True, True, True]  # unknown noise: all
    noise = np.array([0.03, 0.09, 0.1])  # the commands explain 91 %, 19 %, none of it
    assert showable(scale, noise, 0.9).tolist() == [True, True, False]


def test_weights_follow_how_much_the_performer_moves_each_feature() -> None:
    scale = np.array([0.01, 0.01, 0.01])
    weights = MovementWeights(scale, tau_s=1.0, min_weight=0.2, shown=np.ones(3, dtype=bool))
    assert weights.weights().tolist() == [1.0, 1.0, 1.0]  # nothing seen yet: all equal
    for frame in range(90):  # three seconds at 30 fps
        moving = 0.05 * np.sin(frame / 3.0)
        w = weights.update(np.array([moving, 0.004, 0.0]), frame * S // 30)
    assert w[0] == 1.0  # she moves it by far more than the robot's spread: full weight
    assert w[1] == pytest.approx(0.4, abs=0.02)  # 0.004 RMS over a spread of 0.01
    assert w[2] == 0.2  # still: the least weight, never 0


def test_weights_are_a_running_estimate_in_the_frames_own_time() -> None:
    weights = MovementWeights(np.array([0.1]), tau_s=2.0, min_weight=0.1, shown=np.array([True]))
    weights.update(np.array([0.1]), 0)
    assert weights.weights() == pytest.approx([1.0])
    # one tau later at rest: the mean square decays to e^-1 of its value ...
    assert weights.update(np.array([0.0]), 2 * S) == pytest.approx([np.exp(-0.5)])
    # ... a frame whose time does not advance, or a missing value, changes nothing ...
    assert weights.update(np.array([0.0]), 2 * S) == pytest.approx([np.exp(-0.5)])
    assert weights.update(np.array([np.nan]), 10 * S) == pytest.approx([np.exp(-0.5)])
    # ... and a long pause forgets the past: the new frame is all there is
    assert weights.update(np.array([0.0]), 1000 * S) == pytest.approx([0.1])
    weights.reset()
    assert weights.weights() == pytest.approx([1.0])


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_weights_stay_bounded_for_extreme_or_missing_values() -> None:
    weights = MovementWeights(
        np.array([1e-300, 1.0]), tau_s=1.0, min_weight=0.3, shown=np.ones(2, dtype=bool)
    )
    out = weights.update(np.array([1e300, np.inf]), 0)
    assert np.isfinite(out).all() and ((out >= 0.3) & (out <= 1.0)).all()


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("floor", [1.0, 0.5])
def test_extreme_but_valid_files_give_bounded_targets_without_warnings(floor: float) -> None:
    """Found by fuzzing: a valid file's scales may be 1e300 or 5e-324; the running estimate
    overflowed (squares, the weights' level, a region's room) with numpy warnings."""
    low, high = np.array([-1e300, -0.05, -1e-300]), np.array([1e300, 0.1, 5e-324])
    model = Retargeter(
        ["jaw_open", "lips_part", "lip_pucker"],
        low,
        high,
        np.array([1e300, 5e-324, 1.7e308]),
        None,
        Retarget(region_floor=floor),
    )
    for index, change in enumerate([[1e300, 1e-300, 5e-324], [-1e308, 1e308, -1e308], [0, 0, 0]]):
        weights = model.weights.update(np.array(change, dtype=np.float64), index * S)
        assert np.isfinite(weights).all() and (weights >= 0).all() and (weights <= 1).all()
        target = model.targets(np.array(change, dtype=np.float64))
        assert np.isfinite(target).all() and (low <= target).all() and (target <= high).all()
