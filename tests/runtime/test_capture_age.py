"""facesynth.runtime.capture_age: messages aged from their frame's capture, whatever the clocks."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from facesynth.runtime.capture_age import (
    MAX_DRIFT,
    PROBATION_S,
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


# --- what a receiver can vouch for (issue 28: no stale command, even under load and restarts) --


def own(ages: CaptureAge, captured_ns: int, at_ns: int) -> CaptureVerdict:
    """A frame captured at ``captured_ns`` on the receiver's own host ("board"), seen at
    ``at_ns`` (one clock: wall and monotonic alike, for reading)."""
    return ages.check(captured_ns, "board", at_ns, at_ns)


def test_on_its_own_clock_a_loaded_chain_never_becomes_the_baseline() -> None:
    # A soak at load 17: for 40 s every frame takes 200 ms from capture. A baseline learnt from
    # that (the fastest of the last 30 s) would pass a frame 0.45 s old as 0.25 s.
    ages = CaptureAge(0.25, own_host="board")
    t = 10 * S
    for i in range(40 * 30):
        captured = t + i * FRAME_NS
        assert own(ages, captured, captured + 200 * MS).age_s == pytest.approx(0.2)
    t += 40 * S
    late = own(ages, t, t + 260 * MS)
    assert late.old and late.age_s == pytest.approx(0.26)


def test_on_its_own_clock_old_frames_stay_old_however_long_they_last_said_once() -> None:
    # Two seconds and more of nothing but old frames: another host's clock would be re-learnt
    # (a stepped clock); the receiver's own clock cannot have stepped against itself.
    ages = CaptureAge(0.25, own_host="board")
    stream_at = 10 * S
    for i in range(30):
        assert not own(ages, stream_at + i * FRAME_NS, stream_at + i * FRAME_NS + 20 * MS).old
    t = stream_at + S
    verdicts = [own(ages, t + i * FRAME_NS, t + i * FRAME_NS + 300 * MS) for i in range(5 * 30)]
    assert all(v.old for v in verdicts)
    notes = [v.note for v in verdicts if v.note]
    assert len(notes) == 2, notes  # the first old one, then once "too slow here"
    assert "captured 0.30 s ago on 'board' (limit 0.25 s): dropping" in notes[0]
    assert (
        "over the limit for 2.0 s, about 0.30 s old (limit 0.25 s): the chain is too slow"
        in (notes[1])
    )
    back = t + 5 * S
    assert own(ages, back, back + 20 * MS).note.startswith("fresh frames again: dropped 150")


def test_on_its_own_clock_a_frame_from_the_future_is_refused() -> None:
    ages = CaptureAge(0.25, own_host="board")
    t = 10 * S
    assert own(ages, t + 10 * MS, t) == CaptureVerdict(0.0, deadline_ns=t + 260 * MS)
    ahead = own(ages, t + S, t)  # a clock stepped back, or another machine under this name
    assert ahead.old and "1.00 s in the future by this host's own clock" in ahead.note


def test_stamps_from_the_future_that_go_on_are_another_clock_under_this_host_s_name() -> None:
    # A ROS 2 camera on another machine, its clock 3 s ahead: its image stamps are taken as
    # capture times and the frames name this host. Refused while that could be a clock
    # stepped back; after 2 s of it, learnt as another host's clock (from the fastest frame).
    ages = CaptureAge(0.25, own_host="board")
    t = 10 * S
    verdicts = []
    for i in range(90):
        captured = t + i * FRAME_NS
        verdicts.append(own(ages, captured + 3 * S, captured + (12 + i % 3 * 10) * MS))
    switched = next(i for i, v in enumerate(verdicts) if not v.old)
    assert switched * FRAME_NS >= RELEARN_S * S and all(v.old for v in verdicts[:switched])
    assert "came 2.98 s from the future for 2.0 s: not this host's clock after all" in (
        verdicts[switched].note
    )
    assert all(not v.old and v.age_s is not None and v.age_s <= 0.02 for v in verdicts[switched:])
    later = t + 90 * FRAME_NS
    assert own(ages, later + 3 * S - S, later + 12 * MS).old  # a frame held 1 s: old


def test_a_clock_stepped_back_refuses_only_the_frames_in_flight() -> None:
    ages = CaptureAge(0.25, own_host="board")
    t = 10 * S
    for i in range(30):
        assert not own(ages, t + i * FRAME_NS, t + i * FRAME_NS + 12 * MS).old
    t += S  # the receiver's clock steps back 1 s: the 3 frames in flight come "from the future"
    assert all(own(ages, t + S - i * MS, t + 12 * MS).old for i in range(3))
    after = [own(ages, t + i * FRAME_NS, t + i * FRAME_NS + 12 * MS) for i in range(90)]
    assert not any(v.old for v in after)  # stamped after the step: exact again, nothing learnt
    assert own(ages, t + 3 * S, t + 3 * S + 260 * MS).old


def test_the_deadline_is_when_the_age_reaches_the_limit() -> None:
    ages = CaptureAge(0.25, own_host="board")
    assert own(ages, 10 * S, 10 * S + 30 * MS).deadline_ns == 10 * S + 250 * MS
    other = CaptureAge(0.25)
    stream(other, 10 * S, 30)  # 12 ms from capture to the receiver at the fastest
    verdict = seen(other, 20 * S, 20 * S + 40 * MS)
    assert verdict.age_s == pytest.approx(0.028)
    assert verdict.deadline_ns == 20 * S + AHEAD_NS + (12 * MS - AHEAD_NS) + 250 * MS


def test_another_host_s_baseline_rises_no_faster_than_a_clock_drifts() -> None:
    # 12 ms at the fastest, then 40 s of 200 ms (a loaded chain, within the limit): the window
    # alone would have taken 200 ms as the offset after 30 s.
    ages = CaptureAge(0.25)
    stream(ages, 10 * S, 150)
    t = 10 * S + 150 * FRAME_NS
    for i in range(40 * 30):
        assert not seen(ages, t + i * FRAME_NS, t + i * FRAME_NS + 200 * MS).old
    t += 40 * S
    drift = MAX_DRIFT * 45  # what a clock can drift in the 45 s since the fastest frame
    late = seen(ages, t, t + 12 * MS + round((0.25 + drift) * S) + 10 * MS)
    assert late.old


def test_a_re_learnt_baseline_is_the_fastest_of_the_old_run_not_its_last() -> None:
    ages = CaptureAge(0.25)
    stream(ages, 10 * S, 60)
    step = 10 * S + 60 * FRAME_NS
    for i in range(int(RELEARN_S * 30) + 5):  # stamps 5 s behind, and the way jitters 0-200 ms
        captured = step + i * FRAME_NS
        slow = i % 2 == 1
        verdict = seen(ages, captured - 5 * S, captured + 12 * MS + (200 * MS if slow else 0))
        if not verdict.old:
            break
    assert slow and "looked about 5.20 s old" in verdict.note  # re-learnt on a slow one ...
    assert verdict.age_s == pytest.approx(0.2)  # ... yet measured from the fastest of the run
    t = captured + FRAME_NS
    assert not seen(ages, t - 5 * S, t + 12 * MS + 250 * MS).old
    assert seen(ages, t - 5 * S + FRAME_NS, t + FRAME_NS + 12 * MS + 251 * MS).old


def test_a_host_first_seen_is_learnt_before_any_of_its_frames_is_used() -> None:
    # The receiver (re)starts just as a stall upstream lets its backlog go: frames 3 s old
    # come first, at once, then the live ones. Taken as the baseline, the first would have
    # passed the whole backlog as young.
    ages = CaptureAge(0.25, probation_s=PROBATION_S)
    t = 100 * S
    backlog = [seen(ages, t - 3 * S + i * FRAME_NS, t + i * MS) for i in range(5)]
    assert all(v.old and v.age_s is None for v in backlog)
    assert "'camera-host', a clock not yet learnt: none is used for its first 1 s" in (
        backlog[0].note
    )
    assert [v.note for v in backlog[1:]] == [""] * 4
    live = [seen(ages, t + i * FRAME_NS, t + i * FRAME_NS + 12 * MS) for i in range(40)]
    used = [i for i, v in enumerate(live) if not v.old]
    arrived = used[0] * FRAME_NS + 12 * MS  # after the first frame seen
    assert PROBATION_S * S <= arrived < PROBATION_S * S + FRAME_NS
    assert used == list(range(used[0], 40))
    assert live[used[0]].note.startswith("the clock of 'camera-host' is learnt")
    assert all(live[i].age_s == pytest.approx(0.0) for i in used)  # measured from the live
    assert ages.held == 5 + used[0] and ages.old == 0
    assert seen(ages, t, t + 2 * S).old  # a frame of the backlog now: 3 s old


def test_the_receiver_s_own_host_has_no_probation() -> None:
    ages = CaptureAge(0.25, own_host="board", probation_s=PROBATION_S)
    assert not own(ages, 10 * S, 10 * S + 20 * MS).old
    assert own(ages, 10 * S, 10 * S + 3 * S).old  # and is exact from the first


def test_the_probation_must_not_be_negative() -> None:
    with pytest.raises(ValueError, match="probation of a capture host cannot be negative"):
        CaptureAge(0.25, probation_s=-1.0)


#: Up to 60 frames (gap from the previous in ms, way from capture to the receiver in ms):
#: under 2 s in all, so no run of old frames lasts long enough to be re-learnt.
RUNS = st.lists(st.tuples(st.integers(1, 30), st.integers(5, 600)), min_size=1, max_size=60)


@settings(max_examples=300, deadline=None)
@given(RUNS)
def test_no_frame_over_the_limit_is_ever_used_on_the_receivers_own_clock(
    run: list[tuple[int, int]],
) -> None:
    ages = CaptureAge(0.25, own_host="board", probation_s=PROBATION_S)
    captured = 10 * S
    for gap_ms, way_ms in run:
        captured += gap_ms * MS
        verdict = own(ages, captured, captured + way_ms * MS)
        assert verdict.old == (way_ms > 250)


@settings(max_examples=300, deadline=None)
@given(RUNS, st.booleans())
def test_on_another_clock_a_frame_used_is_within_the_limit_of_the_fastest_seen(
    run: list[tuple[int, int]], probation: bool
) -> None:
    # One-way stamps vouch for no more: the age beyond the fastest way seen so far (plus what
    # a clock can drift meanwhile), whatever came first.
    ages = CaptureAge(0.25, probation_s=PROBATION_S if probation else 0.0)
    captured, fastest_ms = 10 * S, 10**9
    for gap_ms, way_ms in run:
        captured += gap_ms * MS
        fastest_ms = min(fastest_ms, way_ms)
        verdict = seen(ages, captured, captured + way_ms * MS)
        if not verdict.old:
            assert way_ms - fastest_ms <= 250 + MAX_DRIFT * 2_000
