"""Record lines and faults -> stale commands, gaps, the largest step (tools/soak/commands.py)."""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.drivers.record import RecordLine, SessionInfo, SessionMarker
from tools.soak.commands import executed, gaps, motion, stale
from tools.soak.schedule import Fault

MS = 1_000_000
T0 = 1_800_000_000 * 1_000_000_000  # a wall clock reading (ns)
PAPER16 = load_profile("paper16")


def line(t_ms: float, frame: int | None = 1, latency_ms: float | None = 20, **servos: float):
    sent = T0 + round(t_ms * MS)
    capture = (
        sent - round(latency_ms * MS) if latency_ms is not None and frame is not None else None
    )
    return RecordLine(
        seq=0, frame=frame, t_capture_ns=capture, t_sent_ns=sent, face=True,
        servos=servos or {"jaw": 1500.0},
    )  # fmt: skip


def fault(kind: str, target: str, t_ms: float) -> Fault:
    return Fault(kind, target, T0 + round(t_ms * MS), T0 + round(t_ms * MS) + 1000 * MS)


def stream(start_ms: float, end_ms: float, every_ms: float = 33.3) -> list[RecordLine]:
    count = int((end_ms - start_ms) / every_ms)
    return [line(start_ms + i * every_ms, frame=i) for i in range(count)]


def test_commands_older_than_the_limit_from_capture_are_stale_and_put_down_to_a_fault() -> None:
    lines = [
        *stream(0, 1000),
        line(5000, frame=900, latency_ms=3020),  # a frame from before the stall, 3 s late
        line(5033, frame=901, latency_ms=2990),
        line(5066, frame=None),  # C's own move: not aged
        line(5100, frame=902, latency_ms=269),  # 249 ms over the fastest way: not stale
        line(5133, frame=903, latency_ms=20),
    ]
    figures = stale(lines, [fault("kill", "translator", 500), fault("stall", "points", 1500)], 0.25)
    assert figures.fastest_s == pytest.approx(0.020)
    assert figures.count == 2
    assert figures.by_kind == {"stall": 2}
    assert [(c.frame, round(c.age_s, 3), c.after) for c in figures.listed] == [
        (900, 3.0, "stall"),
        (901, 2.97, "stall"),
    ]
    assert figures.oldest_s == pytest.approx(3.0)
    assert figures.checked == len(lines) - 1 and figures.unstamped == 0


def test_a_stale_command_is_put_down_by_the_gaps_rule_at_its_capture() -> None:
    # Not "the fault that began last before C sent it": a frame caught in a stall and sent just
    # after a kill began is the stall's; one captured long after every fault ended is "none",
    # as its gap would be; one captured just before a flood began is the flood's.
    lines = [
        *stream(0, 1000),
        line(4100, frame=100, latency_ms=2900),  # captured at 1.2 s, in the stall
        line(20_400, frame=500, latency_ms=400),  # captured at 20 s, 15.7 s after the kill
        line(30_200, frame=800, latency_ms=500),  # captured 0.3 s before the flood began
    ]
    faults = [
        Fault("stall", "points", T0 + 1000 * MS, T0 + 4000 * MS),
        Fault("kill", "router", T0 + 4050 * MS, T0 + 4300 * MS),
        Fault("flood", "input", T0 + 30_000 * MS, T0 + 34_000 * MS),
    ]
    figures = stale(lines, faults, 0.25)
    assert [(c.frame, c.after) for c in figures.listed] == [
        (100, "stall"),
        (500, "none"),
        (800, "flood"),
    ]
    assert figures.by_kind == {"stall": 1, "none": 1, "flood": 1}


def test_commands_without_a_capture_stamp_are_counted_not_aged() -> None:
    figures = stale([line(0, latency_ms=None), line(33, latency_ms=None)], [], 0.25)
    assert (figures.checked, figures.unstamped, figures.count, figures.fastest_s) == (0, 2, 0, None)


def test_the_longest_gap_per_fault_kind() -> None:
    before, first, second, third = (
        stream(0, 1000),  # steady before any fault
        stream(1200, 2000),  # silent from ~1000 ms: the first kill
        stream(3500, 4000),  # silent from ~2000 ms: the router's kill
        stream(4100, 5000),  # silent from ~4000 ms, during the flood
    )
    lines = [
        *before, *first, *second, *third,
        line(5400, frame=None),  # C's own move in between does not close a gap
        *stream(5800, 6000),
    ]  # fmt: skip
    faults = [
        fault("kill", "points", 990),
        fault("kill", "router", 2000),
        fault("flood", "input", 4050),
        fault("stall", "points", 5000),
    ]
    found = gaps(lines, faults)
    assert set(found) == {"none", "kill", "flood", "stall"}
    assert found["kill"].target == "router"

    def after(lines: list[RecordLine], t_ms: float) -> float:
        return (T0 + t_ms * MS - lines[-1].t_sent_ns) / 1e9

    assert found["kill"].seconds == pytest.approx(after(first, 3500))
    assert found["flood"].seconds == pytest.approx(after(second, 4100))
    assert found["stall"].seconds == pytest.approx(after(third, 5800))
    assert found["none"].seconds == pytest.approx(0.0333)


def test_a_gap_is_put_down_to_the_fault_near_when_it_began_not_when_it_ended() -> None:
    # The soak of 2026-11-27: the stream stopped 5 s after a link cut had ended, with no fault
    # under way, and came back only at the next router kill, 57 s later: a gap of its own.
    lines = [
        *stream(0, 1000),
        *stream(1100, 2000),  # silent from ~1000 ms, during the cut (to 1500 ms)
        *stream(5000, 6000),  # silent from ~2000 ms, 0.5 s after the cut: the cut's
        line(12_000),  # silent from ~6000 ms, 3 s after the stall, until the kill at 11 s
        line(14_000),  # silent from 12 s, during the flood; it lasts past the kill at 13.5 s
    ]
    faults = [
        Fault("cut", "board", T0 + 1000 * MS, T0 + 1500 * MS),
        Fault("stall", "points", T0 + 2500 * MS, T0 + 2900 * MS),
        Fault("kill", "router", T0 + 11_000 * MS, T0 + 12_500 * MS),
        Fault("flood", "input", T0 + 11_900 * MS, T0 + 12_100 * MS),
        Fault("kill", "points", T0 + 13_500 * MS, T0 + 13_600 * MS),
    ]
    found = gaps(lines, faults)
    assert set(found) == {"none", "cut", "flood"}
    assert (found["none"].start_ns, found["none"].end_ns) == (lines[-3].t_sent_ns, T0 + 12_000 * MS)
    assert found["none"].target == ""
    assert found["cut"].end_ns == T0 + 5000 * MS and found["cut"].target == "board"
    assert (found["flood"].start_ns, found["flood"].end_ns) == (T0 + 12_000 * MS, T0 + 14_000 * MS)


def test_a_fault_that_begins_just_after_the_last_command_caused_the_gap() -> None:
    lines = [line(0), line(1000), line(4000), line(6000)]
    faults = [
        Fault("kill", "router", T0 + 1400 * MS, T0 + 1500 * MS),  # 0.4 s after the command
        Fault("stall", "points", T0 + 4600 * MS, T0 + 5000 * MS),  # 0.6 s after: too late
    ]
    found = gaps(lines, faults)
    assert found["kill"].start_ns == T0 + 1000 * MS
    assert "stall" not in found and found["none"].start_ns == T0 + 4000 * MS


def test_counts_of_executed_commands() -> None:
    assert executed([line(0), line(33, frame=None), line(66)]) == (2, 1)


def _record(path: Path, *sessions: list[RecordLine]) -> Path:
    encoder = msgspec.json.Encoder()
    with open(path, "wb") as out:
        for number, lines in enumerate(sessions):
            marker = SessionMarker(session=SessionInfo(started_ns=T0 + number, profile="paper16"))
            out.write(encoder.encode(marker) + b"\n")
            for item in lines:
                out.write(encoder.encode(item) + b"\n")
    return path


def test_the_largest_step_against_its_speed_limit(tmp_path: Path) -> None:
    # right_eyebrow may move 3000 µs/s: 60 µs in 33.3 ms is 0.6 of it, 150 µs is over.
    ok = [line(0, right_eyebrow=1500), line(33.3, right_eyebrow=1560)]
    report = motion(_record(tmp_path / "a.jsonl", ok), PAPER16)
    assert report.worst_ratio == pytest.approx(60 / (3000 * (0.0333 + 0.0002) + 0.002), rel=1e-3)
    assert report.over == [] and report.sessions == 1
    fast = [line(100, right_eyebrow=1500), line(133.3, right_eyebrow=1650)]
    report = motion(_record(tmp_path / "b.jsonl", ok, fast), PAPER16)
    assert report.worst_ratio > 1 and len(report.over) == 1 and report.sessions == 2
