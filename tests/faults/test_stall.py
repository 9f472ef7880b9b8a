"""Points frozen for 3 s (SIGSTOP, then SIGCONT) while a stream plays: no old motion after it.

The rig is the fault suite's (:class:`conftest.Rig`), but with the bundled video in real time
and the live tracker, as a performer's chain runs: while P is stopped its input backs up (in the
router, its socket, its input queue) and the frame it was tracking waits with it. When it runs
again those frames, captured up to 3 s before, come out of it first. The control interface must
not execute them: every command the record driver wrote must have been captured at most the
profile's ``max_command_age_s`` before C decided it (one host: the capture and the record share
a clock). The stall degrades to hold, then neutral (the watchdog), and the stream comes back.
Before commands were aged from capture, 2 commands per stall were executed 2.1-2.8 s after their
capture.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import ORDER, Rig
from facesynth_processes import Processes
from motion_check import check_motion

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.drivers.record import RecordLine

pytestmark = pytest.mark.faults

PAPER16 = load_profile("paper16")
LIMIT_NS = round(PAPER16.max_command_age_s * 1e9)
STALL_S = 3.0
STALLS = 2


class TrackerRig(Rig):
    """The fault rig with the bundled video in real time and the live tracker."""

    def args(self, name: str) -> list[str]:
        common = ["--connect", self.router, "--rig", self.rig, "--stats-interval", "0.5"]
        if name == "points":
            return ["points", "--backend", "tracker", *common]
        if name == "sensor":
            waits = "points,features,translator,control"
            return ["sensor", "--source", "video", "--loop", "--wait-for", waits, *common]
        return super().args(name)

    def ready_line(self, name: str) -> str:
        return "sensor: " if name == "sensor" else super().ready_line(name)


def too_old(commands: list[RecordLine]) -> list[tuple[int | None, float]]:
    """(frame, seconds from capture) of the commands executed more than the limit after their
    capture: one host stamps both, and C ages a command on its own clock exactly."""
    return [
        (line.frame, (line.t_sent_ns - (line.t_capture_ns or 0)) / 1e9)
        for line in commands
        if line.t_sent_ns - (line.t_capture_ns or 0) > LIMIT_NS
    ]


@pytest.fixture
def tracker_rig(tmp_path: Path) -> Iterator[Rig]:
    processes = Processes(tmp_path)
    rig = TrackerRig(processes, tmp_path)
    try:
        for name in ORDER:
            rig.start(name)
        rig.wait_for_commands(0, 60, timeout=90)
        yield rig
    finally:
        processes.stop()


def test_a_frozen_points_stage_sends_no_old_motion_when_it_resumes(tracker_rig: Rig) -> None:
    rig = tracker_rig
    points = rig.live["points"]
    rows = []
    for _ in range(STALLS):
        rig.wait_for_commands(time.time_ns(), 30, timeout=15)  # streaming before the stall
        stopped_ns = time.time_ns()
        points.send_signal(signal.SIGSTOP)
        time.sleep(STALL_S)
        points.send_signal(signal.SIGCONT)
        resumed_ns = time.time_ns()
        back = rig.wait_for_commands(resumed_ns, 30, timeout=15)  # and the stream comes back
        rows.append((stopped_ns, resumed_ns, back[0]))
        assert rig.others_alive("") == [], f"{rig.others_alive('')} exited"
    commands = [line for line in rig.lines() if line.frame is not None and line.t_capture_ns]
    old = too_old(commands)
    print()
    for stopped_ns, resumed_ns, back in rows:
        print(
            f"points stopped {(resumed_ns - stopped_ns) / 1e9:.2f} s; the first command after it "
            f"{(back.t_sent_ns - resumed_ns) / 1e9:.2f} s after SIGCONT, captured "
            f"{(back.t_sent_ns - (back.t_capture_ns or 0)) / 1e9:.3f} s before"
        )
    print(f"{len(commands)} commands, {len(old)} older than {LIMIT_NS / 1e9:g} s from capture")
    assert old == [], f"commands executed long after capture (frame, age s): {old[:10]}"
    # Whatever old frames reached a stage were dropped on purpose, said at most once per stall.
    # Whether any reach one is a race, so it is printed, not required: after SIGCONT the
    # transport's thread may fill P's 2-deep queue with fresh frames before P reads it (the
    # backlog is dropped oldest-first, silently), and P may have been idle, not mid-frame, when
    # stopped. The drop itself is tested deterministically in tests/runtime/test_stale_inputs.py.
    said = {
        name: rig.processes.log(rig.log_name(name)).count("dropping")
        for name in ("points", "features", "translator", "control")
    }
    print(f"stale runs said: {said}")
    assert max(said.values()) <= STALLS, said
    # Meanwhile the face held, then went back to neutral (the watchdog), within the limits.
    for stopped_ns, resumed_ns, _ in rows:
        during = [line for line in rig.lines() if stopped_ns < line.t_sent_ns < resumed_ns]
        assert during and during[-1].frame is None, "no return to neutral during the stall"
        assert during[-1].servos == PAPER16.neutral_positions()
    report = check_motion(rig.record, PAPER16)
    print(report.summary())
    assert report.over == [], report.over[:5]
