"""The babbling plan: sweeps, space-filling poses, neutral checks, extremes, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from facesynth.app.learn.plan import EXTREME, Plan, PlanError, PlanOptions, halton, to_pulses
from facesynth.runtime.profiles import load_profile


def _poses(plan: Plan, n: int) -> list[tuple[str, tuple[float, ...]]]:
    return [(p.kind, p.u) for p in (plan.pose(i) for i in range(n))]


def test_the_plan_starts_at_neutral_then_sweeps_each_servo_alone_both_ways() -> None:
    plan = Plan(3, PlanOptions(seed=1, sweep_steps=2, neutral_every=100))
    assert plan.pose(0).kind == "neutral" and plan.pose(0).u == (0.0, 0.0, 0.0)
    sweeps = [plan.pose(i) for i in range(1, plan.sweep_poses)]
    assert all(p.kind == "sweep" for p in sweeps)
    assert [p.u for p in sweeps[:4]] == [(0.5, 0, 0), (1.0, 0, 0), (-0.5, 0, 0), (-1.0, 0, 0)]
    for servo in range(3):  # each servo reaches both ends, the others stay at neutral
        mine = [p.u for p in sweeps if any(p.u[k] for k in range(3) if k != servo) is False]
        values = {u[servo] for u in mine}
        assert {1.0, -1.0} <= values
    assert plan.sweep_poses == 1 + 3 * 4
    assert plan.pose(plan.sweep_poses).kind == "random"


def test_a_neutral_pose_comes_every_k_poses() -> None:
    plan = Plan(4, PlanOptions(seed=2, neutral_every=5))
    for i in range(60):
        pose = plan.pose(i)
        assert (pose.kind == "neutral") == (i % 5 == 0)
        if pose.kind == "neutral":
            assert pose.u == (0.0,) * 4
    assert plan.sweep_poses == 30  # 24 sweep poses and 6 neutral poses among them


def test_random_poses_fill_the_space_within_limits() -> None:
    plan = Plan(5, PlanOptions(seed=3, sweep_steps=1))
    u = np.array([p.u for p in (plan.pose(i) for i in range(400)) if p.kind == "random"])
    assert len(u) > 300
    assert u.min() >= -1.0 and u.max() <= 1.0
    # space-filling: every servo's values cover each tenth of the range
    for servo in range(5):
        counts, _ = np.histogram(u[:, servo], bins=10, range=(-1, 1))
        assert counts.min() >= 15
    # and the servos are not correlated with each other
    corr = np.corrcoef(u.T) - np.eye(5)
    assert np.abs(corr).max() < 0.25


def test_no_extreme_is_held_longer_than_allowed() -> None:
    plan = Plan(6, PlanOptions(seed=4, max_extreme_run=2, sweep_steps=1))
    run = [0] * 6
    for i in range(800):
        u = plan.pose(i).u
        for servo, value in enumerate(u):
            run[servo] = run[servo] + 1 if abs(value) > EXTREME else 0
            assert run[servo] <= 2


def test_the_plan_is_the_same_for_the_same_seed_and_another_for_another() -> None:
    a = _poses(Plan(4, PlanOptions(seed=7)), 120)
    b = Plan(4, PlanOptions(seed=7))
    assert [(p.kind, p.u) for p in (b.pose(i) for i in range(119, -1, -1))][::-1] == a
    c = _poses(Plan(4, PlanOptions(seed=8)), 120)
    assert a != c
    sweeps = Plan(4, PlanOptions(seed=7)).sweep_poses
    assert a[:sweeps] == c[:sweeps]  # neutral and sweeps do not depend on the seed


def test_halton_is_the_van_der_corput_sequence() -> None:
    assert [halton(i, 2) for i in range(1, 5)] == [0.5, 0.25, 0.75, 0.125]
    assert halton(1, 3) == pytest.approx(1 / 3)


def test_pulses_map_neutral_and_both_ends_of_each_servo() -> None:
    profile = load_profile("paper16")
    n = len(profile.servos)
    assert to_pulses(profile, [0.0] * n) == profile.neutral_positions()
    high = to_pulses(profile, [1.0] * n)
    low = to_pulses(profile, [-5.0] * n)  # beyond the range: held to the limits
    for spec in profile.servos:
        assert high[spec.name] == spec.max_us and low[spec.name] == spec.min_us
    half = to_pulses(profile, [0.5] * n)
    spec = profile.servos[0]
    assert half[spec.name] == pytest.approx((spec.neutral_us + spec.max_us) / 2)
    with pytest.raises(PlanError, match="3 values for a profile of 16 servos"):
        to_pulses(profile, [0.0] * 3)


@pytest.mark.parametrize(
    ("servos", "options", "message"),
    [
        (0, PlanOptions(), "1 to 32 servos, not 0"),
        (40, PlanOptions(), "not 40"),
    ],
)
def test_bad_plans_are_refused(servos: int, options: PlanOptions, message: str) -> None:
    with pytest.raises(PlanError, match=message):
        Plan(servos, options)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"seed": -1}, "--seed must be >= 0"),
        ({"sweep_steps": 0}, "at least one step"),
        ({"neutral_every": 1}, "every other pose"),
        ({"max_extreme_run": 0}, "at least one pose"),
    ],
)
def test_bad_plan_options_are_refused(kwargs: dict[str, int], message: str) -> None:
    with pytest.raises(PlanError, match=message):
        PlanOptions(**kwargs)
