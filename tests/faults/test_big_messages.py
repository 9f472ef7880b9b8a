"""Oversized messages at real services: nothing freezes, memory returns to its baseline.

A burst of 20 messages of 18 MB on …/servo_commands (a million-entry positions map, which
froze a control interface for 2 s before the payload limits) and on …/features, and of 4 MB
frames declaring 16000x16000 pixels on …/input, one every 100 ms while the stream plays. The
stream keeps >= 90 % of its rate, the control interface is never silent for longer than its
watchdog promises after a command, and each service's resident memory (VmRSS from /proc)
3 s after the burst is within 10 MB of its level before it (plus Zenoh's reusable receive
buffers where Zenoh delivers the message). Prints the figures.
"""

from __future__ import annotations

import itertools
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import Rig

from facesynth.runtime import keys

pytestmark = pytest.mark.faults

SENDER = Path(__file__).with_name("big_sender.py")
#: (key, what is sent, the service taking that key, whether the service itself refuses it: the
#: 18 MB messages are over the session's Zenoh message limit (limits.session_limit), so Zenoh
#: drops them before reassembly and the service never sees them; the 4 MB frame is under it,
#: and the service refuses it by its JPEG header, logging the refusal.)
BURSTS = [("servo_commands", "commands", "control", False),
          ("features", "bytes", "translator", False),
          ("input", "jpeg", "points", True)]  # fmt: skip
COUNT, INTERVAL_S = 20, 0.1
WATCHDOG_S = 0.5


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise AssertionError(f"no VmRSS for {pid}")


def rate(rig: Rig, start_ns: int, end_ns: int) -> float:
    frames = [line for line in rig.lines() if line.frame is not None]
    return sum(start_ns <= line.t_sent_ns < end_ns for line in frames) / ((end_ns - start_ns) / 1e9)


def longest_silence_after_a_command(rig: Rig, start_ns: int, end_ns: int) -> float:
    lines = [line for line in rig.lines() if start_ns <= line.t_sent_ns < end_ns]
    gaps = [
        (b.t_sent_ns - a.t_sent_ns) / 1e9
        for a, b in itertools.pairwise(lines)
        if a.frame is not None
    ]
    return max(gaps, default=0.0)


def test_oversized_messages_freeze_nothing_and_memory_returns(rig: Rig) -> None:
    rows = []
    for stage, kind, service, refused_by_service in BURSTS:
        time.sleep(3.0)
        pid = rig.live[service].pid
        before_mb = rss_mb(pid)
        sender = subprocess.Popen(
            [sys.executable, str(SENDER), rig.router, keys.stage_key(rig.rig, stage), kind,
             str(COUNT), str(INTERVAL_S)],
            stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        assert sender.stdout is not None
        size = int(sender.stdout.readline().split()[1])
        started = time.time_ns()
        peak_mb = before_mb
        while sender.poll() is None:
            peak_mb = max(peak_mb, rss_mb(pid))
            time.sleep(0.05)
        ended = time.time_ns()
        assert sender.returncode == 0
        time.sleep(3.0)
        after_mb = rss_mb(pid)
        stream = rate(rig, started, ended)
        baseline = rate(rig, started - 2_000_000_000, started)
        silence = longest_silence_after_a_command(rig, started, ended)
        rows.append((stage, size, service, before_mb, peak_mb, after_mb, stream, baseline, silence))
        assert rig.others_alive("") == [], f"{rig.others_alive('')} exited"
        if refused_by_service:
            refused = rig.processes.log(rig.log_name(service))
            assert "refused on arrival" in refused, f"{service} said nothing of the refusals"
    print()
    for stage, size, service, before, peak, after, stream, baseline, silence in rows:
        print(
            f"{COUNT} x {size / 1e6:.1f} MB on {stage:<14}: {service} RSS {before:.1f} MB before, "
            f"{peak:.1f} MB at most during, {after:.1f} MB 3 s after; commands {stream:.1f}/s "
            f"({baseline:.1f}/s before); longest silence after a command {silence:.2f} s"
        )
    for (stage, size, service, before, _, after, stream, baseline, silence), burst in zip(
        rows, BURSTS, strict=True
    ):
        # What Zenoh reassembles, it reassembles in receive buffers that it keeps for reuse:
        # they grow once, to a few times the largest message delivered, then stay (measured:
        # 4 MB messages, 20 then 40 more, ~21 MB kept after the first burst and no more after).
        # Messages Zenoh drops at the session's limit leave nothing.
        kept = 10 + (8 * size / 1e6 if burst[3] else 0)
        assert after <= before + kept, f"{service} kept {after - before:.1f} MB after {stage}"
        assert stream >= 0.9 * baseline, f"{stage}: {stream:.1f}/s against {baseline:.1f}/s"
        assert silence <= WATCHDOG_S + 0.2, f"{stage}: control silent {silence:.2f} s"
