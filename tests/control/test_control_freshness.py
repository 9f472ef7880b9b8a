"""services.control.freshness: older and old commands are refused, whatever the hosts' clocks."""

from __future__ import annotations

from typing import Any

import pytest

from schemas.messages import ServoCommands
from services.control.freshness import (
    RELEARN_COUNT,
    RELEARN_S,
    WINDOW_S,
    Arrival,
    Freshness,
    StaleCommand,
)

MS = 1_000_000
S = 1_000_000_000
#: The translator host's clock is an hour and a bit ahead of the controller's.
AHEAD_NS = 3_600 * S + 123 * MS


def cmd(seq: int, sent_ns: int, *, sender: str = "t-1/ab", host: str = "tracker", **kw: Any):
    return ServoCommands(
        seq=seq,
        t_capture_ns=1,
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


def test_the_age_limit_must_be_positive() -> None:
    with pytest.raises(ValueError, match="positive"):
        Freshness(0.0)
