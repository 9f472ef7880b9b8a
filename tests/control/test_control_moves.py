"""services.control.core in time given as data: start-up, catching up, the return to neutral,
shutdown and reports, and that none of them steps a servo faster than its profile allows."""

from __future__ import annotations

import itertools
from typing import Any

import msgspec
import pytest

from facesynth.runtime.profiles import Profile, ServoSpec, load_profile
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.core import (
    MAX_STEP_S,
    RAMP_RATE_HZ,
    REPORT_S,
    Arrival,
    CommandError,
    ControlCore,
    Move,
    StaleCommand,
)

MS = 1_000_000
S = 1_000_000_000
STEP_NS = round(MAX_STEP_S * S)
PAPER16 = load_profile("paper16")
NEUTRAL16 = PAPER16.neutral_positions()
FREE = Profile(  # no speed limits; the default neutral_ramp_s of 0.5 s
    name="free",
    servos=[
        ServoSpec(
            name="jaw", channel=0, min_us=1000, neutral_us=1500, max_us=2000, feature="jaw_open"
        ),
        ServoSpec(
            name="brow", channel=1, min_us=1000, neutral_us=1500, max_us=2000, feature="jaw_open"
        ),
    ],
)
STEPS = round(FREE.neutral_ramp_s * RAMP_RATE_HZ)


def cmd(seq: int, profile: str = "paper16", t_media_ms: int = 0, **positions: float) -> Any:
    return ServoCommands(
        seq=seq,
        t_capture_ns=7,
        t_media_ns=t_media_ms * MS,
        face=True,
        profile=profile,
        positions=positions,
    )


def send(core: ControlCore, commands: ServoCommands, t_ns: int) -> Move:
    move, _ = core.command(commands, Arrival(t_ns, t_ns))
    return move


def run_until(core: ControlCore, end_ns: int) -> list[tuple[int, Move]]:
    """Every move the core makes on its own until ``end_ns``, ticking when it says."""
    moves = []
    while (due := core.due_ns()) <= end_ns:
        move = core.tick(due)
        if move is not None:
            moves.append((due, move))
    return moves


def assert_within_limits(profile: Profile, timeline: list[tuple[int, dict[str, float]]]) -> None:
    """No step between two sends exceeds max_speed x the time between them."""
    for (t0, a), (t1, b) in itertools.pairwise(timeline):
        for spec in profile.servos:
            if spec.max_speed > 0:
                dt = (t1 - t0) / S
                assert abs(b[spec.name] - a[spec.name]) <= spec.max_speed * dt + 1e-6, (spec, t1)


def test_a_far_command_after_start_is_reached_within_the_speed_limits() -> None:
    core = ControlCore(PAPER16, watchdog_s=5.0)
    timeline = [(0, core.start(0).positions)]
    move = send(core, cmd(0, jaw=2000.0, right_eyebrow=1000.0, right_eye_x=2000.0), 20 * MS)
    timeline.append((20 * MS, move.positions))
    assert move.positions["right_eyebrow"] == pytest.approx(1500 - 3000 * 0.02)
    assert move.positions["right_eye_x"] == pytest.approx(1500 + 6000 * 0.02)
    assert 1500 < move.positions["jaw"] < 1500 + 2500 * 0.02  # accelerating
    moves = run_until(core, 2 * S)
    steps = [(t, m) for t, m in moves if m.send]
    assert {m.kind for _, m in steps} == {"catch-up"}
    assert [t for t, _ in steps][:3] == [20 * MS + i * STEP_NS for i in (1, 2, 3)]
    timeline += [(t, m.positions) for t, m in steps]
    assert_within_limits(PAPER16, timeline)
    assert core.positions["jaw"] == 2000.0 and core.positions["right_eyebrow"] == 1000.0
    # The jaw (2500 µs/s, 30000 µs/s²) took longest: about 0.2 s + 0.08 s of ramping.
    assert 0.25 * S < steps[-1][0] < 0.4 * S
    reports = [(t, m) for t, m in moves if not m.send]
    assert reports and all(m.kind == "report" for _, m in reports)
    assert reports[0][0] == steps[-1][0] + round(REPORT_S * S)


def test_silence_returns_to_neutral_in_even_steps_exactly_after_watchdog_plus_ramp() -> None:
    core = ControlCore(FREE, watchdog_s=0.5)
    core.start(0)
    send(core, cmd(0, "free", jaw=1500.0), 10 * MS)  # reached: the catch-up is over
    send(core, cmd(1, "free", jaw=2000.0), 1 * S)  # last command at 1.0 s
    assert core.positions["jaw"] == 2000.0
    moves = [(t, m) for t, m in run_until(core, 3 * S) if m.send]
    assert [t for t, _ in moves] == [1500 * MS + i * 500 * MS // STEPS for i in range(1, 13)]
    assert {m.kind for _, m in moves} == {"return"}
    jaw = [m.positions["jaw"] for _, m in moves]
    assert jaw == pytest.approx([2000.0 - 500.0 * i / STEPS for i in range(1, STEPS + 1)])
    assert moves[-1] == (2000 * MS, Move("return", {"jaw": 1500.0, "brow": 1500.0}, t_ns=2000 * MS))
    assert core.mode == "idle"


def test_the_return_to_neutral_never_outruns_a_servo_s_limits() -> None:
    slow = msgspec.structs.replace(
        PAPER16,
        servos=[msgspec.structs.replace(s, max_speed=500.0) for s in PAPER16.servos],
    )
    core = ControlCore(slow, watchdog_s=0.5)
    timeline = [(0, core.start(0).positions)]
    timeline.append((1 * MS, send(core, cmd(0, jaw=2000.0), 1 * MS).positions))
    timeline += [(t, m.positions) for t, m in run_until(core, 5 * S) if m.send]
    assert_within_limits(slow, timeline)
    assert timeline[-1][1] == NEUTRAL16


def test_a_command_interrupts_the_return_and_unlimited_servos_catch_up_again() -> None:
    core = ControlCore(FREE, watchdog_s=0.5)
    core.start(0)
    send(core, cmd(0, "free", jaw=1500.0), 10 * MS)
    send(core, cmd(1, "free", jaw=2000.0), 1 * S)
    fourth = 1500 * MS + 4 * 500 * MS // STEPS
    run_until(core, fourth)  # four steps of the return
    assert core.mode == "return"
    back = send(core, cmd(2, "free", jaw=2000.0, brow=2000.0), fourth + 10 * MS)
    # Catching up again: full travel (1000 µs) per 0.5 s, 10 ms since the last step.
    assert back.positions["brow"] == pytest.approx(1500.0 + 2000.0 * 0.01)
    assert core.mode == "follow"


def test_reports_while_idle_say_where_the_face_is_without_moving_it() -> None:
    core = ControlCore(PAPER16)
    core.start(0)
    moves = run_until(core, 2 * S)
    assert [(t, m.kind, m.send) for t, m in moves] == [
        (i * round(REPORT_S * S), "report", False) for i in range(1, 5)
    ]
    assert all(m.positions == NEUTRAL16 for _, m in moves)


def test_stopping_returns_to_neutral_within_the_limits_and_in_the_budget() -> None:
    core = ControlCore(PAPER16)
    timeline = [(0, core.start(0).positions)]
    timeline.append(
        (10 * MS, send(core, cmd(0, jaw=2000.0, right_eyebrow=1000.0), 10 * MS).positions)
    )
    timeline += [(t, m.positions) for t, m in run_until(core, 1 * S) if m.send]
    stop_at = 1 * S + 3 * MS
    core.stop(stop_at)
    moves = run_until(core, stop_at + round(core.stop_budget_s() * S))
    sends = [(t, m) for t, m in moves if m.send]
    assert {m.kind for _, m in sends} == {"stop"}
    assert core.stopped and sends[-1][1].positions == NEUTRAL16
    assert sends[-1][0] - stop_at <= core.stop_budget_s() * S
    assert_within_limits(PAPER16, timeline + [(t, m.positions) for t, m in sends])
    with pytest.raises(CommandError, match="stopping"):
        send(core, cmd(1, jaw=1800.0), 5 * S)


def test_media_time_gives_the_same_positions_however_the_commands_arrive() -> None:
    def play(arrivals_ms: list[int]) -> list[dict[str, float]]:
        core = ControlCore(PAPER16, motion_time="media")
        core.start(0)
        out = []
        for i, arrival in enumerate(arrivals_ms):
            target = 2000.0 if i < 10 else 1000.0
            out.append(send(core, cmd(i, t_media_ms=i * 33, jaw=target), arrival * MS).positions)
            assert core.due_ns() >= (arrival + 400) * MS  # no catch-up of its own in media time
        return out

    fast = play([i * 3 for i in range(20)])  # a --fast replay: ten times real time
    late = play([i * 50 for i in range(20)])
    assert fast == late
    jaw = [p["jaw"] for p in fast]
    assert all(abs(b - a) <= 2500 * 0.033 + 1e-6 for a, b in itertools.pairwise(jaw))


def test_refused_commands_neither_move_nor_delay_the_watchdog() -> None:
    core = ControlCore(FREE, watchdog_s=0.5)
    core.start(0)
    send(core, cmd(0, "free", jaw=1500.0), 10 * MS)
    due = core.due_ns()
    for i in range(1000):  # a flood of commands for another profile, one every 0.1 ms
        with pytest.raises(CommandError):
            send(core, cmd(i, "other", jaw=2000.0), 10 * MS + i * 100_000)
    assert core.due_ns() == due == 10 * MS + 500 * MS


def test_a_stale_command_does_not_move_the_face() -> None:
    core = ControlCore(PAPER16, own_host="board")
    core.start(0)
    stale = msgspec.structs.replace(
        cmd(0, jaw=2000.0), sender="t/1", sender_seq=1, sent_ns=1 * S, sender_host="board"
    )
    with pytest.raises(StaleCommand, match=r"is 2\.000 s old"):
        core.command(stale, Arrival(3 * S, 3 * S))
    assert core.positions == NEUTRAL16 and core.mode == "idle"
