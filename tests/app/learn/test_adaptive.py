"""The adaptive babbling plan (facesynth.app.learn.adaptive): fine sweeps, then poses that
move one region of the face at a time, then the poses the self-model is least sure of; and
fine sweeps tell dead bands and saturation to a sixth of the travel."""

from __future__ import annotations

import numpy as np
from synthetic_babble import SyntheticHead, hardware

from facesynth.app.learn.adaptive import AdaptiveOptions, AdaptivePlan
from facesynth.app.learn.responsive import responsive_range

SERVOS = ("a", "b", "c", "d")
INPUTS = ["f0", "f1", "f2", "f3"]


def _face(u: np.ndarray) -> np.ndarray:
    """Servos a and b move feature f0 together (one region), c moves f1, d moves f2 and f3."""
    return 0.1 * np.array([u[0] + u[1], u[2], u[3], 0.5 * u[3]])


def _run(poses: int, options: AdaptiveOptions) -> tuple[AdaptivePlan, list]:  # type: ignore[type-arg]
    plan = AdaptivePlan(SERVOS, INPUTS, options)
    rng = np.random.default_rng(0)
    taken = []
    for index in range(poses):
        pose = plan.pose(index)
        u = np.array(pose.u)
        plan.observe(pose.kind, u, _face(u) + rng.normal(0.0, 1e-4, 4))
        taken.append(pose)
    return plan, taken


def test_fine_sweeps_then_region_poses_then_least_sure_poses() -> None:
    options = AdaptiveOptions(region_poses=40, batch=10, candidates=100)
    plan, taken = _run(140, options)
    sweeps = [p for p in taken if p.kind == "sweep"]
    assert len(sweeps) == 4 * 2 * 6
    levels = sorted({round(abs(v), 6) for p in sweeps for v in p.u if v})
    assert levels == [round(k / 6, 6) for k in range(1, 7)]
    assert plan.regions.groups == ((0, 1), (2,), (3,))
    after = [p for p in taken[plan.base.sweep_poses :] if p.kind != "neutral"]
    region, rest = after[:40], after[40:]
    groups = [tuple(np.flatnonzero(np.abs(p.u) > 0)) for p in region]
    assert all(g in plan.regions.groups for g in groups)  # one region at a time
    assert {(0, 1), (2,), (3,)} <= set(groups)
    assert rest and all(np.count_nonzero(p.u) == 4 for p in rest)  # the whole face
    assert all(np.all(np.abs(p.u) <= 1.0) for p in taken)


def test_the_least_sure_poses_are_chosen_from_the_ensemble_and_replay_the_same() -> None:
    options = AdaptiveOptions(region_poses=20, batch=10, candidates=100)
    first = [p.u for p in _run(120, options)[1]]
    again = [p.u for p in _run(120, options)[1]]
    assert first == again
    # after region poses, the ensemble asks for whole-face poses toward the ends of the
    # travel, where the poses seen so far pin the face down least
    _, taken = _run(120, options)
    last = np.array([p.u for p in taken[-20:] if p.kind == "random"])
    assert len(last) >= 10
    assert np.abs(last).mean() > 0.5  # uniform candidates average 0.5: the far ones chosen


def _swept_range(steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The responsive ranges found by ``steps``-step sweeps on a synthetic head whose servo 8
    stops changing the face beyond |u| = 0.5."""
    head = SyntheticHead(saturation={8: 0.5}, noise=0.002)
    rows, kinds = [np.zeros(16)] * 10, ["neutral"] * 10
    for servo in range(16):
        for level in range(1, steps + 1):
            for sign in (1.0, -1.0):
                u = np.zeros(16)
                u[servo] = sign * level / steps
                rows.append(u)
                kinds.append("sweep")
    u = np.array(rows)
    return responsive_range(head.features(u), u, np.array(kinds))


def test_six_step_sweeps_find_saturation_to_a_sixth_and_cut_nothing_that_moves() -> None:
    low, high = _swept_range(6)
    assert (low[8], high[8]) == (-0.5, 0.5)
    others = [s for s in range(16) if s != 8]
    # nothing cut by more than the last sixth (where a tanh-shaped feature flattens)
    assert np.all(low[others] <= -5 / 6) and np.all(high[others] >= 5 / 6)
    assert np.mean(np.r_[low[others] == -1.0, high[others] == 1.0]) >= 0.8
    _, high3 = _swept_range(3)
    assert high3[8] == 2 / 3  # three steps: to a third only


def test_hardware_profile_sized_plan_stays_within_limits() -> None:
    servos = tuple(s.name for s in hardware().servos)
    plan = AdaptivePlan(servos, INPUTS, AdaptiveOptions(region_poses=5, batch=5, candidates=20))
    for index in range(plan.base.sweep_poses + 12):
        pose = plan.pose(index)
        plan.observe(pose.kind, np.array(pose.u), np.zeros(4))
        assert len(pose.u) == 16 and max(abs(v) for v in pose.u) <= 1.0


def test_a_weak_steady_servo_swept_in_six_steps_keeps_its_travel() -> None:
    # One feature, moved steadily by one servo to 4 thresholds at the full travel: 2/3 of a
    # threshold from one sixth to the next, which the step-to-step rule took for saturation.
    rng = np.random.default_rng(0)
    neutral = rng.normal(0.0, 0.01, (12, 1))
    threshold = 4.0 * neutral.std()
    levels = np.array([k / 6 for k in range(1, 7)] + [-k / 6 for k in range(1, 7)])
    u = np.concatenate([np.zeros(12), levels])[:, None]
    t = np.concatenate([neutral, 4.0 * threshold * levels[:, None]])
    kinds = np.array(["neutral"] * 12 + ["sweep"] * 12)
    low, high = responsive_range(t, u, kinds)
    assert low[0] <= -5 / 6 and high[0] >= 5 / 6
