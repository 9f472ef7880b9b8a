"""services.control.freshness: older and old commands are refused, whatever the hosts' clocks."""

from __future__ import annotations

from typing import Any

import msgspec
import pytest

from facesynth.runtime import codec
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.freshness import (
    PROBATION_S,
    RELEARN_COUNT,
    RELEARN_S,
    WINDOW_S,
    Arrival,
    Freshness,
    StaleCapture,
    StaleCommand,
)

MS = 1_000_000
S = 1_000_000_000
#: The translator host's clock is an hour and a bit ahead of the controller's.
AHEAD_NS = 3_600 * S + 123 * MS


def cmd(
    seq: int,
    sent_ns: int,
    *,
    sender: str = "t-1/ab",
    host: str = "tracker",
    t_capture_ns: int = 1,
    **kw: Any,
) -> ServoCommands:
    return ServoCommands(
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=1,
        face=True,
        profile="rig",
        positions={},
        sender=sender,
        sender_seq=seq,
        sent_ns=sent_ns,
        sender_host=host,
        **kw,
    )


def at(t_ns: int) -> Arrival:
    """Arrival at controller time ``t_ns`` (wall and monotonic alike, for reading)."""
    return Arrival(wall_ns=t_ns, mono_ns=t_ns)


def live(fresh: Freshness, first: int, count: int, *, start_ns: int, latency_ns: int = 2 * MS):
    """``count`` commands at 30 Hz, each arriving ``latency_ns`` after it was sent."""
    for i in range(count):
        sent = start_ns + i * 33 * MS
        fresh.check(cmd(first + i, sent + AHEAD_NS), at(sent + latency_ns))


def test_a_live_stream_from_a_host_with_another_clock_is_fresh() -> None:
    fresh = Freshness(0.25)
    ages = []
    for i in range(100):
        sent = 10 * S + i * 33 * MS
        latency = (3 + (i * 7) % 40) * MS  # jitter up to 42 ms
        ages.append(fresh.check(cmd(i + 1, sent + AHEAD_NS), at(sent + latency)).age_s)
    assert max(ages) < 0.045  # ages are delays beyond the fastest delivery, not the offset


def test_a_backlog_a_healed_link_delivers_is_dropped_until_the_fresh_commands() -> None:
    fresh = Freshness(0.25)
    live(fresh, 1, 60, start_ns=10 * S)  # two seconds of live stream: the baseline
    cut_start = 10 * S + 60 * 33 * MS
    heal = cut_start + 4 * S
    # Everything sent during the 4 s cut arrives at once when it heals, oldest first.
    outcomes = []
    for i in range(120):
        sent = cut_start + i * 33 * MS
        try:
            fresh.check(cmd(61 + i, sent + AHEAD_NS), at(heal + i * 10_000))
            outcomes.append("run")
        except StaleCommand as exc:
            outcomes.append(str(exc))
    executed = [i for i, o in enumerate(outcomes) if o == "run"]
    assert executed and min(executed) >= 113  # only the last ~0.25 s of the backlog
    assert "is 3.998" in outcomes[0] and "s old (limit 0.25 s)" in outcomes[0]


def test_a_command_not_newer_than_one_applied_is_refused() -> None:
    fresh = Freshness(0.25)
    fresh.check(cmd(5, 10 * S), at(10 * S + MS))
    fresh.check(cmd(6, 10 * S + 33 * MS), at(10 * S + 34 * MS))
    for seq, sent in ((6, 10 * S + 33 * MS), (5, 10 * S)):
        with pytest.raises(StaleCommand, match=f"command {seq} of t-1/ab is not newer than 6"):
            fresh.check(cmd(seq, sent), at(10 * S + 40 * MS))


def test_a_restarted_sender_counting_from_one_again_is_newer() -> None:
    fresh = Freshness(0.25)
    fresh.check(cmd(5000, 10 * S), at(10 * S + MS))
    assert fresh.check(cmd(1, 11 * S), at(11 * S + MS)).age_s == pytest.approx(0.0)


def test_another_sender_takes_over_and_is_said_to_be_new() -> None:
    fresh = Freshness(0.25)
    first = fresh.check(cmd(1, 10 * S), at(10 * S + MS))
    same = fresh.check(cmd(2, 10 * S + 33 * MS), at(10 * S + 34 * MS))
    other = fresh.check(cmd(1, 11 * S, sender="t-2/cd"), at(11 * S + MS))
    assert (first.new_sender, same.new_sender, other.new_sender) == (False, False, True)


def test_commands_from_the_controllers_own_host_are_aged_from_the_first() -> None:
    fresh = Freshness(0.25, own_host="board")
    with pytest.raises(StaleCommand, match=r"is 3\.000 s old"):
        fresh.check(cmd(1, 10 * S, host="board"), at(13 * S))
    assert fresh.check(cmd(2, 13 * S, host="board"), at(13 * S + MS)).age_s == pytest.approx(0.001)


def test_the_first_command_of_an_unknown_host_sets_its_baseline() -> None:
    # One-way stamps cannot age the very first command of a host with an unknown clock.
    fresh = Freshness(0.25, own_host="board")
    assert fresh.check(cmd(1, 10 * S + AHEAD_NS), at(10 * S)).age_s == 0.0


def test_a_clock_stepped_back_is_relearnt_after_a_while_of_old_looking_commands() -> None:
    fresh = Freshness(0.25)
    live(fresh, 1, 30, start_ns=10 * S)
    # The sender's clock steps back by 2 s: every command now looks 2 s old.
    refused, note = 0, ""
    for i in range(200):
        arrival = 12 * S + i * 33 * MS
        try:
            verdict = fresh.check(cmd(31 + i, arrival + AHEAD_NS - 2 * S), at(arrival + 2 * MS))
        except StaleCommand:
            refused += 1
            continue
        note = note or verdict.note
    assert refused == pytest.approx(RELEARN_S / 0.033, abs=2) and refused >= RELEARN_COUNT
    assert "looked about 2.00 s old for 2.0 s: taking that as its clock offset" in note


def test_the_newest_baseline_survives_a_long_silence() -> None:
    fresh = Freshness(0.25)
    live(fresh, 1, 30, start_ns=10 * S)
    later = 10 * S + 5 * round(WINDOW_S) * S  # far beyond the window
    with pytest.raises(StaleCommand, match=r"is 2\.998 s old"):  # held 3 s (baseline: 2 ms)
        fresh.check(cmd(31, later - 3 * S + AHEAD_NS), at(later))


def test_commands_without_stamps_run_unaged_and_that_is_said_once() -> None:
    fresh = Freshness(0.25)
    plain = ServoCommands(
        seq=1, t_capture_ns=1, t_media_ns=1, face=True, profile="rig", positions={}
    )
    notes = [fresh.check(plain, at(10 * S + i)).note for i in range(3)]
    assert notes[0].startswith("commands without send stamps") and notes[1:] == ["", ""]
    assert fresh.check(plain, at(99 * S)).age_s is None


#: The camera host's clock is 5 s behind the controller's (and the translator's is ahead).
BEHIND_NS = -5 * S


def captured(seq: int, capture_ns: int, sent_ns: int) -> ServoCommands:
    """Command ``seq`` of a frame captured at controller time ``capture_ns`` on the camera host,
    translated and sent at controller time ``sent_ns`` on the translator's host."""
    return cmd(seq, sent_ns + AHEAD_NS, t_capture_ns=capture_ns + BEHIND_NS, capture_host="camera")


def capture_stream(fresh: Freshness, first: int, count: int, start_ns: int) -> None:
    """``count`` commands at 30 Hz, 12 ms from capture to send, 2 ms from send to arrival,
    once the camera's clock is learnt: its probation's commands, in the second and a bit
    before ``start_ns``, are refused (and applied none)."""
    learning = start_ns - round(PROBATION_S * S) - 2 * 33 * MS
    for capture in range(learning, learning + round(PROBATION_S * S), 33 * MS):
        with pytest.raises(StaleCapture, match="whose clock is being learnt"):
            fresh.check(captured(first, capture, capture + 12 * MS), at(capture + 14 * MS))
    for i in range(count):
        capture = start_ns + i * 33 * MS
        verdict = fresh.check(
            captured(first + i, capture, capture + 12 * MS), at(capture + 14 * MS)
        )
        assert verdict.capture_age_s is not None and verdict.capture_age_s < 0.001


def test_a_command_sent_fresh_but_captured_long_ago_is_refused_said_once_per_stall() -> None:
    # Points stalled 3 s; the frames it held come through F and T at once afterwards: fresh by
    # the translator's send stamp, 3 s old from capture, on a third host's clock.
    fresh = Freshness(0.25, own_host="board")
    capture_stream(fresh, 1, 60, 10 * S)
    resumed = 10 * S + 60 * 33 * MS + 3 * S
    refusals = []
    for i in range(3):
        backlog = captured(61 + i, resumed - 3 * S + i * 33 * MS, resumed + i * MS)
        with pytest.raises(StaleCapture) as refused:
            fresh.check(backlog, at(resumed + i * MS + 2 * MS))
        refusals.append(refused.value)
    assert str(refusals[0]).startswith("command 61 of t-1/ab (frame 61) was captured 2.988 s ago")
    assert "(limit 0.25 s)" in str(refusals[0])
    assert "captured 2.99 s ago on 'camera' (limit 0.25 s): dropping" in refusals[0].note
    assert [r.note for r in refusals[1:]] == ["", ""]  # once per stall, not per command
    assert isinstance(refusals[0], StaleCommand)  # a stale command like any other
    live_now = captured(64, resumed + 20 * MS, resumed + 32 * MS)
    verdict = fresh.check(live_now, at(resumed + 34 * MS))
    assert verdict.note == "fresh commands again: dropped 3 captured up to 2.99 s before"
    assert fresh.capture.old == 3


def test_a_command_refused_for_its_capture_is_not_counted_as_applied() -> None:
    fresh = Freshness(0.25)
    capture_stream(fresh, 1, 30, 10 * S)
    now = 12 * S
    with pytest.raises(StaleCapture):
        fresh.check(captured(31, now - 2 * S, now), at(now + 2 * MS))
    # The same sender's next command is newer than the last one applied (30), not than 31.
    assert fresh.check(captured(31, now, now + MS), at(now + 3 * MS)).capture_age_s is not None


def test_a_capture_over_the_limit_is_refused_just_within_it_is_not() -> None:
    fresh = Freshness(0.25)
    capture_stream(fresh, 1, 30, 10 * S)  # the fastest way: 14 ms from capture to arrival
    now = 12 * S
    assert not fresh.check(captured(31, now - 250 * MS, now), at(now + 14 * MS)).note
    with pytest.raises(StaleCapture):
        fresh.check(captured(32, now - 250 * MS, now + MS), at(now + 15 * MS))


def test_the_capture_is_aged_when_the_command_leaves_the_queue_not_when_it_arrived() -> None:
    fresh = Freshness(0.25)
    capture_stream(fresh, 1, 30, 10 * S)
    now = 12 * S  # arrived young, then waited 300 ms in the controller's input queue
    waited = Arrival(wall_ns=now + 14 * MS, mono_ns=now + 314 * MS, taken_ns=now + 314 * MS)
    with pytest.raises(StaleCapture, match=r"captured 0\.300 s ago"):
        fresh.check(captured(31, now, now + 12 * MS), waited)


def test_an_old_sender_without_a_capture_host_is_decoded_and_not_aged_from_capture() -> None:
    # A translator from before capture hosts: its payload has no such field at all.
    stamped = codec.encode(cmd(1, 10 * S + AHEAD_NS, t_capture_ns=1))
    fields = msgspec.msgpack.decode(stamped)
    del fields["capture_host"]
    old_sender = codec.decode(msgspec.msgpack.encode(fields), ServoCommands)
    assert old_sender.capture_host == ""
    fresh = Freshness(0.25)
    verdict = fresh.check(old_sender, at(10 * S))  # captured "at 1 ns", half a century ago
    assert verdict.capture_age_s is None and verdict.age_s == 0.0
    assert fresh.capture.unaged == 1


def test_unstamped_commands_are_still_aged_from_their_capture() -> None:
    fresh = Freshness(0.25, own_host="board")
    plain = ServoCommands(
        seq=1,
        t_capture_ns=10 * S,
        t_media_ns=1,
        face=True,
        profile="rig",
        positions={},
        capture_host="board",
    )
    with pytest.raises(StaleCapture, match="an unstamped sender"):
        fresh.check(plain, at(11 * S))


def test_the_age_limit_must_be_positive() -> None:
    with pytest.raises(ValueError, match="positive"):
        Freshness(0.0)


def test_a_controller_that_starts_as_a_backlog_arrives_executes_none_of_it() -> None:
    # C restarted while points was stalled: the first commands it hears were captured 3 s
    # earlier on the camera host (fresh by the translator's send stamps), then the live ones.
    fresh = Freshness(0.25, own_host="board")
    t = 100 * S
    for i in range(5):
        backlog = captured(1 + i, t - 3 * S + i * 33 * MS, t + i * MS)
        with pytest.raises(StaleCapture, match="'camera', whose clock is being learnt"):
            fresh.check(backlog, at(t + i * MS + 2 * MS))
    executed = []
    for i in range(60):
        capture = t + i * 33 * MS
        try:
            verdict = fresh.check(
                captured(6 + i, capture, capture + 12 * MS), at(capture + 14 * MS)
            )
        except StaleCapture:
            continue
        executed.append(i)
        assert verdict.capture_age_s is not None and verdict.capture_age_s < 0.001
    assert executed == list(range(30, 60))  # after the camera's probation (1 s and 10 commands)
    assert fresh.capture.held == 5 + 30 and fresh.capture.old == 0


def test_a_command_sent_in_the_future_by_the_controllers_own_clock_is_refused() -> None:
    fresh = Freshness(0.25, own_host="board")
    with pytest.raises(StaleCommand, match=r"sent 3\.000 s in the future by this host's own"):
        fresh.check(cmd(1, 13 * S, host="board"), at(10 * S))


def test_the_verdict_says_until_when_the_capture_is_young() -> None:
    fresh = Freshness(0.25, own_host="board")
    own = cmd(1, 10 * S, host="board", t_capture_ns=10 * S - 20 * MS, capture_host="board")
    assert fresh.check(own, at(10 * S + MS)).capture_deadline_ns == 10 * S + 230 * MS
    assert fresh.check(cmd(2, 10 * S + 33 * MS), at(10 * S + 34 * MS)).capture_deadline_ns is None
