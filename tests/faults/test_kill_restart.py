"""Kill -9 each service and the router while a stream plays, then start it again.

Per fault: no other process exits; commands reach the servos again within 2 s of the restarted
process being ready; and over the whole run no servo steps faster than its profile allows
(every session of the record file checked against paper16's limits and the lines' time stamps).
Prints, per fault, how long the commands stopped and how soon they came back.
"""

from __future__ import annotations

import time

import pytest
from conftest import ORDER, Rig
from motion_check import check_motion

from facesynth.runtime.profiles import load_profile

pytestmark = pytest.mark.faults

BACK_WITHIN_S = 2.0
PAPER16 = load_profile("paper16")


def test_every_process_killed_and_restarted_mid_stream(rig: Rig) -> None:
    rows = []
    for name in ORDER:
        killed_ns = time.time_ns()
        rig.kill(name)
        time.sleep(1.0)  # a second without it
        assert rig.others_alive(name) == [], f"{rig.others_alive(name)} exited with {name}"
        ready = rig.start(name)
        ready_ns = time.time_ns() - round((time.monotonic() - ready) * 1e9)
        back = rig.wait_for_commands(ready_ns, 1, timeout=15)[0]
        gap_s = (back.t_sent_ns - killed_ns) / 1e9
        after_ready_s = (back.t_sent_ns - ready_ns) / 1e9
        rows.append((name, gap_s, after_ready_s))
        assert after_ready_s <= BACK_WITHIN_S, f"{name}: commands {after_ready_s:.2f} s after ready"
        rig.wait_for_commands(back.t_sent_ns, 30, timeout=15)  # and keep flowing
        assert rig.others_alive("") == [], f"{rig.others_alive('')} exited after {name}"
    report = check_motion(rig.record, PAPER16)
    print()
    for name, gap_s, after_ready_s in rows:
        print(
            f"kill -9 {name:<10}: no commands for {gap_s:.2f} s; back {after_ready_s:.2f} s "
            "after it was ready again"
        )
    print(report.summary())
    for jump in report.boundary_jumps:
        print(f"  control restarted: {jump} (a board's own limits move it there)")
    assert report.over == [], report.over[:5]
    assert report.steps > 1000
