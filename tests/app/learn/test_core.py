"""The babbler's pure core with time as data: a simulated robot answers its commands."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest

from facesynth.app.learn.core import BabbleError, BabbleOptions, Babbler, Budget, Sample
from facesynth.app.learn.plan import Plan, PlanOptions, to_pulses
from facesynth.app.learn.settle import (
    Settle,
    SettleError,
    SettleOptions,
    StalledError,
    average,
    steady,
)
from facesynth.runtime.profiles import Profile, load_profile

MS = 1_000_000
TICK = 33 * MS  # the shell's step and the camera's frame period


def _profile() -> Profile:
    return load_profile("paper16")


@dataclass
class Robot:
    """Servos that follow commands at once; a face whose features are the servos' offsets,
    lagging one frame; the face can be hidden."""

    profile: Profile
    visible: bool = True
    positions: dict[str, float] = field(default_factory=dict)
    commands: list[dict[str, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.positions = self.profile.neutral_positions()

    def face(self) -> dict[str, float]:
        neutral = self.profile.neutral_positions()
        return {f"f_{k}": (v - neutral[k]) / 1000 for k, v in self.positions.items()}


def run(
    babbler: Babbler,
    robot: Robot,
    *,
    start_ns: int = 0,
    until_ns: int = 120_000 * MS,
    hide: tuple[int, int] | None = None,
    stop_at: int | None = None,
) -> tuple[list[Sample], int, list[str]]:
    """Step the babbler and the robot until done; returns the samples, the end time, phases."""
    now = start_ns
    samples: list[Sample] = []
    phases: list[str] = []
    last_face = robot.face()
    features_on = False
    while now < until_ns and not babbler.done:
        if stop_at is not None and now >= stop_at:
            babbler.stop()
        robot.visible = hide is None or not hide[0] <= now < hide[1]
        babbler.servos(robot.positions, now)
        if babbler.at_neutral:
            features_on = True
        if features_on:
            babbler.features(robot.visible, last_face if robot.visible else {}, True, now)
        last_face = robot.face()
        step = babbler.step(now)
        if not phases or phases[-1] != step.phase:
            phases.append(step.phase)
        robot.commands.append(step.targets)
        robot.positions = dict(step.targets)
        if step.sample is not None:
            samples.append(step.sample)
        now += TICK
    return samples, now, phases


def test_it_homes_learns_the_neutral_then_takes_its_budget_of_poses() -> None:
    profile = _profile()
    plan = Plan(16, PlanOptions(seed=3))
    babbler = Babbler(profile, plan, budget=Budget(poses=12))
    samples, _, phases = run(babbler, Robot(profile))
    assert phases == ["homing", "neutral", "babbling", "finishing", "done"]
    assert [s.pose.index for s in samples] == list(range(12))
    assert [s.pose.kind for s in samples[:3]] == ["neutral", "sweep", "sweep"]
    for sample in samples:
        assert sample.commanded == to_pulses(profile, sample.pose.u)
        assert sample.reported == sample.commanded
        assert sample.face.settled and sample.face.frames == 4
        neutral = profile.neutral_positions()
        for name, value in sample.commanded.items():  # the face the camera saw at that pose
            assert sample.face.features[f"f_{name}"] == pytest.approx((value - neutral[name]) / 1e3)
    assert babbler.commanded == profile.neutral_positions()


def test_no_servo_is_commanded_faster_than_its_pace() -> None:
    profile = _profile()
    options = BabbleOptions(pace=0.5)
    babbler = Babbler(profile, Plan(16), budget=Budget(poses=40), options=options)
    robot = Robot(profile)
    run(babbler, robot)
    dt = TICK / 1e9
    for before, after in zip(robot.commands, robot.commands[1:], strict=False):
        for spec in profile.servos:
            step = abs(after[spec.name] - before[spec.name])
            assert step <= 0.5 * spec.max_speed * dt + 1e-6
            assert spec.min_us <= after[spec.name] <= spec.max_us


def test_a_resumed_run_continues_the_same_plan() -> None:
    profile = _profile()
    whole, _, _ = run(
        Babbler(profile, Plan(16, PlanOptions(seed=5)), budget=Budget(40)), Robot(profile)
    )
    first, _, _ = run(
        Babbler(profile, Plan(16, PlanOptions(seed=5)), budget=Budget(25)), Robot(profile)
    )
    rest, _, _ = run(
        Babbler(profile, Plan(16, PlanOptions(seed=5)), start=25, budget=Budget(40)), Robot(profile)
    )
    assert [s.commanded for s in first + rest] == [s.commanded for s in whole]
    assert [s.pose.index for s in rest] == list(range(25, 40))


def test_a_lost_face_sends_the_servos_to_neutral_and_pauses_until_it_is_back() -> None:
    profile = _profile()
    babbler = Babbler(profile, Plan(16, PlanOptions(seed=1)), budget=Budget(poses=30))
    robot = Robot(profile)
    samples, _, phases = run(babbler, robot, hide=(12_000 * MS, 15_000 * MS))
    assert "paused" in phases
    assert phases[-2:] == ["finishing", "done"]
    assert [s.pose.index for s in samples] == list(range(30))  # the pose in progress was redone
    # while the face was gone, the servos went back to neutral
    hidden_end = (15_000 * MS) // TICK
    assert robot.commands[hidden_end - 1] == profile.neutral_positions()
    assert babbler.skipped == 0


def test_a_slow_chain_is_no_lost_face_and_each_pose_is_judged_on_its_own_frames() -> None:
    """Every frame reaches the babbler 1.5 s after it was taken (a loaded tracker): the face is
    not lost meanwhile (it keeps arriving), and each pose's face is that of frames taken after
    the servos got there, never the face of the pose before."""
    profile = _profile()
    babbler = Babbler(profile, Plan(16, PlanOptions(seed=3)), budget=Budget(poses=12))
    robot = Robot(profile)
    latency, now = 1_500 * MS, 0
    taken: list[tuple[int, dict[str, float]]] = []  # (when, the face then), in order
    phases: list[str] = []
    samples: list[Sample] = []
    while not babbler.done and now < 200_000 * MS:
        babbler.servos(robot.positions, now)
        taken.append((now, robot.face()))
        if babbler.at_neutral:
            shown = [(t, face) for t, face in taken if t <= now - latency]
            if shown:
                babbler.features(True, shown[-1][1], True, shown[-1][0], now)
        step = babbler.step(now)
        phases.append(step.phase)
        robot.positions = dict(step.targets)
        if step.sample is not None:
            samples.append(step.sample)
        now += TICK
    assert babbler.done and "paused" not in phases
    assert [s.pose.index for s in samples] == list(range(12))
    neutral = profile.neutral_positions()
    for sample in samples:
        own = {f"f_{k}": (v - neutral[k]) / 1000 for k, v in sample.commanded.items()}
        assert sample.face.features == pytest.approx(own)


def test_a_pose_that_always_loses_the_face_is_skipped() -> None:
    profile = _profile()
    options = BabbleOptions(max_face_retries=1)
    babbler = Babbler(profile, Plan(16), budget=Budget(poses=4), options=options)
    robot = Robot(profile)
    now = 0
    # the face is seen at neutral only: every pose away from it hides it
    while not babbler.done and now < 60_000 * MS:
        babbler.servos(robot.positions, now)
        visible = robot.positions == profile.neutral_positions()
        if babbler.at_neutral:
            babbler.features(visible, robot.face() if visible else {}, True, now)
        step = babbler.step(now)
        robot.positions = step.targets
        now += TICK
    assert babbler.done
    assert babbler.skipped == 3 and babbler.taken == 1  # only the neutral pose could be seen


def test_ctrl_c_returns_to_neutral_and_ends() -> None:
    profile = _profile()
    babbler = Babbler(profile, Plan(16), budget=Budget(poses=500))
    robot = Robot(profile)
    samples, _, phases = run(babbler, robot, stop_at=10_000 * MS)
    assert phases[-2:] == ["finishing", "done"]
    assert babbler.done and 0 < len(samples) < 500
    assert robot.positions == profile.neutral_positions()


def test_a_time_budget_ends_babbling() -> None:
    profile = _profile()
    babbler = Babbler(profile, Plan(16), budget=Budget(until_ns=8_000 * MS))
    samples, end, _ = run(babbler, Robot(profile))
    assert babbler.done and samples and end < 12_000 * MS


def test_babbling_waits_for_the_features_neutral() -> None:
    profile = _profile()
    babbler = Babbler(profile, Plan(16), budget=Budget(poses=2))
    now = 0
    for _ in range(100):
        babbler.servos(profile.neutral_positions(), now)
        babbler.features(True, {"x": 0.0}, False, now)
        assert babbler.step(now).phase in ("homing", "neutral")
        now += TICK
    assert babbler.at_neutral
    babbler.features(True, {"x": 0.0}, True, now)
    assert babbler.step(now).phase == "babbling"


def test_a_plan_for_other_servos_is_refused() -> None:
    with pytest.raises(BabbleError, match="plan for 3 servos cannot drive profile 'paper16'"):
        Babbler(_profile(), Plan(3))
    with pytest.raises(BabbleError, match="pace"):
        BabbleOptions(pace=1.5)


# --- settling --------------------------------------------------------------------------------


def test_a_pose_settles_once_reached_and_the_face_holds_still() -> None:
    settle = Settle({"a": 1500.0}, 0, SettleOptions(frames=3, min_wait_s=0.1, feature_tol=0.01))
    settle.face({"x": 1.0}, 10 * MS)  # not there yet: ignored
    settle.servos({"a": 1400.0}, 20 * MS)
    assert settle.reached_ns is None
    settle.servos({"a": 1495.0}, 40 * MS)
    assert settle.reached_ns == 40 * MS
    settle.face({"x": 0.5}, 100 * MS)  # within the minimum wait: ignored
    for i, value in enumerate([0.3, 0.2, 0.205, 0.21]):
        settle.face({"x": value, "y": 1.0}, (200 + 33 * i) * MS)
    result = settle.check(400 * MS)
    assert result is not None and result.settled and result.frames == 3
    assert result.features["x"] == pytest.approx(0.205)


def test_a_face_that_never_holds_still_is_taken_at_the_longest_wait() -> None:
    settle = Settle({"a": 1500.0}, 0, SettleOptions(frames=3, max_wait_s=1.0, min_wait_s=0.0))
    settle.servos({"a": 1500.0}, 0)
    for i in range(20):
        settle.face({"x": (-1) ** i * 0.5}, i * 40 * MS)
    assert settle.check(900 * MS) is None
    result = settle.check(1000 * MS)
    assert result is not None and not result.settled and result.frames == 3


def test_servos_that_never_arrive_stall() -> None:
    settle = Settle({"a": 1500.0}, 0, SettleOptions(reach_timeout_s=2.0))
    settle.servos({"a": 1000.0}, 0)
    assert settle.check(1_900 * MS) is None
    with pytest.raises(StalledError, match="within 2 s"):
        settle.check(2_100 * MS)


def test_average_and_steady_take_features_some_frames_lack() -> None:
    mean, spread = average([{"x": 1.0, "y": 2.0}, {"x": 3.0}])
    assert mean == {"x": 2.0, "y": 2.0} and spread == {"x": 1.0, "y": 0.0}
    assert average([]) == ({}, {})
    assert steady([{"x": 1.0, "y": 0.0}, {"x": 1.001, "z": 5.0}], 0.01)
    assert not steady([{"x": 1.0}, {"y": 1.0}], 0.01)  # nothing in common
    # one noisy feature of many does not hold the pose up; many do
    calm = {f"f{i}": 0.0 for i in range(20)}
    assert steady([calm, {**calm, "f0": 1.0}], 0.01)
    assert not steady([calm, {k: 1.0 for k in calm}], 0.01)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"frames": 0}, "at least one frame"),
        ({"feature_tol": 0}, "tolerances must be positive"),
        ({"min_wait_s": 2, "max_wait_s": 1}, "minimum <= maximum"),
        ({"reach_timeout_s": 0}, "reach timeout"),
    ],
)
def test_bad_settle_options_are_refused(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(SettleError, match=message):
        SettleOptions(**kwargs)  # type: ignore[arg-type]


def test_servos_never_reported_at_neutral_stall_the_start() -> None:
    options = BabbleOptions(settle=SettleOptions(reach_timeout_s=1.0))
    babbler = Babbler(_profile(), Plan(16), budget=Budget(poses=2), options=options)
    babbler.step(0)
    assert babbler.step(900 * MS).phase == "homing"
    with pytest.raises(StalledError, match="not reported at neutral within 1 s"):
        babbler.step(1_100 * MS)


def test_the_end_does_not_wait_for_reports_that_never_come() -> None:
    options = BabbleOptions(settle=SettleOptions(reach_timeout_s=1.0))
    babbler = Babbler(_profile(), Plan(16), budget=Budget(poses=2), options=options)
    babbler.stop()
    assert babbler.step(0).phase == "finishing"
    assert babbler.step(500 * MS).phase == "finishing"
    assert babbler.step(1_100 * MS).phase == "done"
