"""facesynth.runtime.capture_age: messages aged from their frame's capture, whatever the clocks."""

from __future__ import annotations

import pytest

from facesynth.runtime.capture_age import (
    RELEARN_COUNT,
    RELEARN_S,
    WINDOW_S,
    CaptureAge,
    CaptureVerdict,
    OffsetBaseline,
)

MS = 1_000_000
S = 1_000_000_000
#: The capture host's clock is an hour and a bit ahead of the receiver's.
AHEAD_NS = 3_600 * S + 123 * MS
CAMERA = "camera-host"
FRAME_NS = 33 * MS


def seen(ages: CaptureAge, captured_ns: int, at_ns: int, host: str = CAMERA) -> CaptureVerdict:
    """A frame captured at receiver time ``captured_ns`` (stamped on ``host``'s clock, ahead),
    seen at receiver time ``at_ns`` (wall and monotonic alike, for reading)."""
    return ages.check(captured_ns + AHEAD_NS, host, at_ns, at_ns)


def stream(ages: CaptureAge, start_ns: int, count: int, latency_ns: int = 12 * MS) -> None:
    for i in range(count):
        captured = start_ns + i * FRAME_NS
        assert not seen(ages, captured, captured + latency_ns).old


def test_a_live_stream_from_a_host_with_another_clock_is_young() -> None:
    ages = CaptureAge(0.25)
    found = []
    for i in range(100):
        captured = 10 * S + i * FRAME_NS
        latency = (8 + (i * 7) % 40) * MS  # jitter up to 47 ms
        verdict = seen(ages, captured, captured + latency)
        assert not verdict.old and verdict.note == ""
        found.append(verdict.age_s)
    assert max(a for a in found if a is not None) < 0.045  # the delay beyond the fastest


def test_a_stall_s_backlog_is_dropped_said_once_then_fresh_frames_go_on() -> None:
    ages = CaptureAge(0.25)
    stream(ages, 10 * S, 60)
    stall = 10 * S + 60 * FRAME_NS
    resumed = stall + 3 * S
    # Frozen for 3 s: the frames of just before the stall come out first, then live ones.
    verdicts = [seen(ages, stall - (3 - i) * FRAME_NS, resumed + i * MS) for i in range(3)]
    assert [v.old for v in verdicts] == [True, True, True]
    assert verdicts[0].age_s == pytest.approx(3.0 + 3 * FRAME_NS / S - 0.012, abs=1e-6)
    assert "captured 3.09 s ago on 'camera-host' (limit 0.25 s): dropping" in verdicts[0].note
    assert [v.note for v in verdicts[1:]] == ["", ""]  # once per stall, not per frame
    fresh = seen(ages, resumed, resumed + 15 * MS)
    assert not fresh.old
    assert fresh.note == "fresh frames again: dropped 3 captured up to 3.09 s before"
    assert ages.old == 3
    assert seen(ages, resumed + FRAME_NS, resumed + FRAME_NS + 12 * MS).note == ""
    # The next stall is a new run, said again.
    later = resumed + 5 * S
    assert "dropping" in seen(ages, later - S, later).note


def test_just_within_the_limit_is_young_just_over_is_old() -> None:
    ages = CaptureAge(0.25)
    stream(ages, 10 * S, 30, latency_ns=10 * MS)
    t = 20 * S
    assert not seen(ages, t, t + 10 * MS + 250 * MS).old
    assert seen(ages, t, t + 10 * MS + 251 * MS).old


def test_frames_from_the_receivers_own_host_are_aged_from_the_first() -> None:
    ages = CaptureAge(0.25, own_host="board")
    first = ages.check(10 * S, "board", 13 * S, 13 * S)  # same clock: 3 s old, the first seen
    assert first.old and first.age_s == pytest.approx(3.0)


def test_the_first_frame_of_another_host_sets_its_baseline() -> None:
    ages = CaptureAge(0.25, own_host="board")
    first = seen(ages, 10 * S, 10 * S + 3 * S)  # its clock is unknown: taken as it comes
    assert not first.old and first.age_s == 0.0
    assert not seen(ages, 11 * S, 14 * S).old
    assert seen(ages, 12 * S, 15 * S + 300 * MS).old  # later than that by more than the limit


def test_each_capture_host_has_its_own_offset() -> None:
    ages = CaptureAge(0.25)
    stream(ages, 10 * S, 30)
    behind = -7 * S  # a second camera host, whose clock is 7 s behind the receiver's
    for i in range(30):
        captured = 10 * S + i * FRAME_NS
        verdict = ages.check(captured + behind, "camera-2", captured + 20 * MS, captured + 20 * MS)
        assert not verdict.old
    assert not seen(ages, 12 * S, 12 * S + 12 * MS).old


def test_messages_without_a_capture_host_or_stamp_are_not_aged() -> None:
    ages = CaptureAge(0.25, own_host="board")
    assert ages.check(1, "", 10**18, 5 * S) == CaptureVerdict(None)  # an older sender, a replay
    assert ages.check(0, "board", 10**18, 5 * S) == CaptureVerdict(None)  # no capture stamp
    assert ages.unaged == 2 and ages.old == 0


def test_a_capture_clock_stepped_back_is_relearnt_after_a_while_of_old_looking_frames() -> None:
    ages = CaptureAge(0.25)
    stream(ages, 10 * S, 60)
    step = 10 * S + 60 * FRAME_NS
    notes = []
    for i in range(int(RELEARN_S * 30) + 5):  # stamps now 5 s behind what they were
        captured = step + i * FRAME_NS
        verdict = ages.check(captured + AHEAD_NS - 5 * S, CAMERA, captured + 12 * MS, captured)
        notes.append((verdict.old, verdict.note))
    relearnt = next(i for i, (old, _) in enumerate(notes) if not old)
    assert relearnt >= RELEARN_COUNT and relearnt * FRAME_NS >= RELEARN_S * S
    assert "looked about 5.00 s old for 2.0" in notes[relearnt][1]
    assert all(not old for old, _ in notes[relearnt:])


def test_the_baseline_window_follows_drift_and_keeps_its_newest_bucket() -> None:
    baseline = OffsetBaseline()
    baseline.add(0, 5 * MS)
    baseline.add(round((WINDOW_S + 2) * S), 9 * MS)  # the first bucket is out of the window
    assert baseline.baseline() == 9 * MS
    assert len(baseline.buckets) == 1  # the newest never expires, however long the silence


def test_the_limit_must_be_positive() -> None:
    with pytest.raises(ValueError, match="capture age limit must be positive"):
        CaptureAge(0.0)
