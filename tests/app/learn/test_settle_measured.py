"""Settling on measured positions: where the driver reads the servos back, a pose counts as
reached when the servos *are* there (within the tolerance), with no fixed wait; a servo that
never gets there (held by the skin) is given a timeout, then the pose is taken and says so;
without read-back the fixed wait stays."""

from __future__ import annotations

import itertools

from facesynth.app.learn.core import BabbleOptions, Babbler, Budget
from facesynth.app.learn.plan import Plan, PlanOptions
from facesynth.app.learn.settle import Settle, SettleOptions
from facesynth.runtime.profiles import load_profile

MS = 1_000_000
OPTIONS = SettleOptions(frames=2, min_wait_s=1.0, feature_tol=0.01, measured_timeout_s=0.5)


def still_face(settle: Settle, start_ms: int, count: int = 3) -> None:
    for i in range(count):
        settle.face({"x": 0.2}, (start_ms + 33 * i) * MS)


def test_a_pose_is_reached_when_the_measured_positions_get_there() -> None:
    settle = Settle({"a": 1600.0}, 0, OPTIONS)
    settle.servos({"a": 1600.0}, 10 * MS, measured={"a": 1500.0})  # commanded, not there
    assert settle.reading and settle.reached_ns is None
    settle.servos({"a": 1600.0}, 60 * MS, measured={"a": 1570.0})
    assert settle.reached_ns is None  # 30 µs off: outside the 20 µs tolerance
    settle.servos({"a": 1600.0}, 90 * MS, measured={"a": 1585.0})
    assert settle.reached_ns == 90 * MS and settle.reached == "measured"
    still_face(settle, 100)  # no 1 s minimum wait: the frames count at once
    result = settle.check(170 * MS)
    assert result is not None and result.settled and result.reached == "measured"


def test_a_servo_that_never_gets_there_is_taken_after_the_timeout() -> None:
    settle = Settle({"a": 1600.0, "b": 1500.0}, 0, OPTIONS)
    settle.servos({"a": 1600.0, "b": 1500.0}, 10 * MS, measured={"a": 1540.0, "b": 1500.0})
    assert settle.check(500 * MS) is None and settle.reached_ns is None
    assert settle.check(510 * MS) is None  # 0.5 s after C reported it: taken as it is
    assert settle.reached_ns == 510 * MS and settle.reached == "measured timeout"
    still_face(settle, 520)
    result = settle.check(600 * MS)
    assert result is not None and result.reached == "measured timeout"


def test_without_read_back_the_fixed_wait_stays() -> None:
    settle = Settle({"a": 1600.0}, 0, OPTIONS)
    settle.servos({"a": 1600.0}, 10 * MS)
    assert not settle.reading and settle.reached_ns == 10 * MS
    still_face(settle, 100)  # within the 1 s minimum wait: ignored
    assert settle.check(200 * MS) is None
    still_face(settle, 1100)
    result = settle.check(1200 * MS)
    assert result is not None and result.reached == "commanded"


def test_readings_of_only_some_servos_keep_the_fixed_wait() -> None:
    settle = Settle({"a": 1600.0, "b": 1500.0}, 0, OPTIONS)
    settle.servos({"a": 1600.0, "b": 1500.0}, 10 * MS, measured={"a": 1600.0})
    assert not settle.reading and settle.reached == "commanded"


def test_the_babbler_settles_on_measured_positions_and_records_them() -> None:
    """Servos that move at a finite speed and report where they are: every pose is taken once
    they are there, well before a 2 s fixed wait would allow, with the measured positions."""
    profile = load_profile("paper16")
    plan = Plan(len(profile.servos), PlanOptions(seed=1))
    options = BabbleOptions(settle=SettleOptions(frames=2, min_wait_s=2.0, max_wait_s=4.0))
    babbler = Babbler(profile, plan, budget=Budget(poses=6), options=options)
    measured = profile.neutral_positions()
    speed = 4000.0  # µs/s
    now, tick = 0, 33 * MS
    samples = []
    while not babbler.done and now < 120_000 * MS:
        commanded = babbler.commanded
        for name, goal in commanded.items():
            step = speed * tick / 1e9
            here = measured[name]
            measured[name] = goal if abs(goal - here) <= step else here + step * (goal > here or -1)
        babbler.servos(commanded, now, measured)
        if babbler.at_neutral:
            face = {f"f_{k}": (v - 1500) / 1000 for k, v in measured.items()}
            babbler.features(True, face, True, now)
        step_ = babbler.step(now)
        if step_.sample is not None:
            samples.append((now, step_.sample))
        now += tick
    assert len(samples) == 6
    for _, sample in samples:
        assert sample.face.reached == "measured"
        assert all(abs(sample.measured[n] - v) <= 20 for n, v in sample.commanded.items())
    assert babbler.reached == {"measured": 6}
    gaps = [b - a for (a, _), (b, _) in itertools.pairwise(samples)]
    assert max(gaps) < 2_000 * MS  # no pose waited the 2 s fixed wait
