"""facesynth.services.control.motion: no step of any servo is faster than its profile allows."""

from __future__ import annotations

import itertools
import math

import msgspec
import pytest

from facesynth.runtime.profiles import Profile, ServoSpec, load_profile
from facesynth.services.control.motion import MAX_STEP_S, FaceMotion


def servo(name: str, channel: int, **limits: float) -> ServoSpec:
    return ServoSpec(
        name=name,
        channel=channel,
        min_us=1000,
        neutral_us=1500,
        max_us=2000,
        feature="jaw_open",
        **limits,  # type: ignore[arg-type]
    )


PROFILE = Profile(
    name="rig",
    neutral_ramp_s=0.5,
    servos=[
        servo("fast", 0, max_speed=6000),
        servo("heavy", 1, max_speed=2500, max_accel=30000),
        servo("free", 2),  # no max_speed: catches up after start, then unlimited
        servo("accel", 3, max_accel=20000),
    ],
)


def _run(motion: FaceMotion, targets: dict[str, float], dts: list[float]) -> list[dict]:
    return [motion.step(targets, dt) for dt in dts]


def test_each_step_is_within_max_speed_times_its_time() -> None:
    motion = FaceMotion(PROFILE)
    path = [dict(motion.positions), *_run(motion, {"fast": 2000.0}, [0.01, 0.033, 0.02, 0.04])]
    steps = [b["fast"] - a["fast"] for a, b in itertools.pairwise(path)]
    assert steps == pytest.approx([60.0, 198.0, 120.0, 122.0])  # the last one arrives


def test_a_long_pause_counts_as_one_max_step() -> None:
    motion = FaceMotion(PROFILE)
    after = motion.step({"fast": 2000.0}, 10.0)  # ten seconds since the last step
    assert after["fast"] == pytest.approx(1500.0 + 6000 * MAX_STEP_S)


def test_no_time_no_move_unless_unlimited() -> None:
    motion = FaceMotion(PROFILE)
    for dt in (0.0, -1.0):
        assert motion.step({"fast": 2000.0, "free": 2000.0}, dt) == PROFILE.neutral_positions()
    motion.catching_up.clear()
    assert motion.step({"fast": 2000.0, "free": 2000.0}, 0.0)["free"] == 2000.0


def test_acceleration_and_speed_bound_a_heavy_servo_which_stops_at_its_target() -> None:
    motion = FaceMotion(PROFILE)
    dt = 0.02
    positions = [p["heavy"] for p in _run(motion, {"heavy": 2000.0}, [dt] * 40)]
    velocities = [(b - a) / dt for a, b in itertools.pairwise([1500.0, *positions])]
    assert max(abs(v) for v in velocities) <= 2500 + 1e-6
    changes = [abs(b - a) / dt for a, b in itertools.pairwise([0.0, *velocities])]
    assert max(changes) <= 30000 + 1e-6
    assert positions[-1] == 2000.0 and motion.velocities["heavy"] == 0.0
    assert all(p <= 2000.0 for p in positions)


def test_an_accel_only_servo_is_bounded_by_its_acceleration() -> None:
    motion = FaceMotion(PROFILE)
    first = motion.step({"accel": 2000.0}, 0.02)["accel"]
    assert first - 1500.0 == pytest.approx(20000 * 0.02 * 0.02)


def test_a_servo_without_max_speed_catches_up_then_follows_at_once() -> None:
    motion = FaceMotion(PROFILE)  # catching up from the start: full travel (1000 µs) per 0.5 s
    first = motion.step({"free": 2000.0}, 0.04)["free"]
    assert first == pytest.approx(1500.0 + 2000.0 * 0.04)
    for _ in range(10):
        motion.step({"free": 2000.0}, 0.04)
    assert motion.positions["free"] == 2000.0 and "free" not in motion.catching_up
    assert motion.step({"free": 1000.0}, 0.001)["free"] == 1000.0  # no limit once there
    motion.catch_up()  # e.g. a new translator took over
    assert motion.step({"free": 2000.0}, 0.04)["free"] == pytest.approx(1000.0 + 80.0)


def test_without_a_neutral_ramp_a_servo_without_max_speed_jumps() -> None:
    motion = FaceMotion(msgspec.structs.replace(PROFILE, neutral_ramp_s=0.0))
    assert motion.step({"free": 2000.0}, 0.001)["free"] == 2000.0


def test_targets_are_clamped_and_servos_not_named_hold() -> None:
    motion = FaceMotion(PROFILE)
    for _ in range(30):
        motion.step({"fast": 99999.0, "free": -math.inf}, 0.04)
    assert motion.positions["fast"] == 2000.0 and motion.positions["free"] == 1000.0
    assert motion.positions["heavy"] == 1500.0
    assert motion.reached({"fast": 2000.0, "free": 1000.0})
    assert not motion.reached({"fast": 1999.0})


def test_the_max_step_is_what_a_servo_may_move_in_a_step() -> None:
    motion = FaceMotion(PROFILE)
    assert motion.max_step_us("fast", 0.01) == pytest.approx(60.0)
    assert motion.max_step_us("fast", 1.0) == pytest.approx(6000 * MAX_STEP_S)
    motion.catching_up.clear()
    assert motion.max_step_us("free", 0.01) == math.inf


@pytest.mark.parametrize("name", ["paper16", "head16", "virtual", "arkit52"])
def test_shipped_profiles_never_step_beyond_their_limits(name: str) -> None:
    profile = load_profile(name)
    motion = FaceMotion(profile)
    targets_cycle = [
        {s.name: s.max_us for s in profile.servos},
        {s.name: s.min_us for s in profile.servos},
        profile.neutral_positions(),
    ]
    before = dict(motion.positions)
    for i, dt in enumerate([0.001, 0.033, 0.5, 0.02, 0.04] * 30):
        after = motion.step(targets_cycle[(i // 7) % 3], dt)
        for spec in profile.servos:
            step = abs(after[spec.name] - before[spec.name])
            assert spec.min_us <= after[spec.name] <= spec.max_us
            bound = motion.max_step_us(spec.name, dt)
            if spec.name in motion.catching_up or spec.max_speed > 0:
                assert step <= bound + 1e-6
        before = after


def test_a_step_needs_positive_time_to_cover() -> None:
    with pytest.raises(ValueError, match="positive time"):
        FaceMotion(PROFILE, max_step_s=0.0)
