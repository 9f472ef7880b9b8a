"""A flood on every key while a stream plays: the legitimate commands keep >= 90 % of their rate.

One key at a time, a flooding publisher process (tests/faults/flooder.py: garbage, wrong types,
bad values, oversized payloads; bounded to 4 s and 500,000 messages) publishes on loopback at
10,000 messages/s, 300 times the stream's rate. The rate of the stream's commands reaching the
servos (record lines per second) during the flood is compared with the same window just before
it. No process may exit, and no servo may step faster than its profile allows. Then each key is
flooded as fast as the flooder can publish (tens of thousands a second, which on two shared
cores leaves the services little CPU): there the rates are measured and printed, and only
"nothing exits, no servo too fast" is required.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import Rig
from motion_check import check_motion

from facesynth.runtime import keys
from facesynth.runtime.profiles import load_profile

pytestmark = pytest.mark.faults

FLOOD_S = 4.0
FLOOD_COUNT = 500_000
FLOOD_RATE = 10_000
KEPT = 0.90
FLOODER = Path(__file__).with_name("flooder.py")


def rate(rig: Rig, start_ns: int, end_ns: int) -> float:
    count = sum(
        1 for line in rig.lines() if line.frame is not None and start_ns <= line.t_sent_ns < end_ns
    )
    return count / ((end_ns - start_ns) / 1e9)


def flood(rig: Rig, stage: str, key: str, rate_hz: int) -> tuple[float, float, float]:
    """Flood ``key``; return the flood's rate, and the stream's before (the 2 s just before,
    3 s after any earlier flood) and during it (/s)."""
    time.sleep(3.0)
    args = [rig.router, key, stage, str(FLOOD_S), str(FLOOD_COUNT), str(rate_hz)]
    flooder = subprocess.Popen(
        [sys.executable, str(FLOODER), *args], stdout=subprocess.PIPE, text=True
    )
    assert flooder.stdout is not None and flooder.stdout.readline().strip() == "flooding"
    started = time.time_ns()
    out, _ = flooder.communicate(timeout=60)
    ended = time.time_ns()
    sent = json.loads(out.strip().splitlines()[-1])["sent"]
    window = ended - started
    time.sleep(0.5)  # the last commands of the window are on file
    assert rig.others_alive("") == [], f"{rig.others_alive('')} exited in the {stage} flood"
    before = rate(rig, started - 2_000_000_000, started)
    return sent / (window / 1e9), before, rate(rig, started, ended)


def targets(rig: Rig) -> list[tuple[str, str]]:
    found = [(stage, keys.stage_key(rig.rig, stage)) for stage in keys.STAGES]
    return [*found, ("stats", keys.stats_key(rig.rig, "translator", "flooder"))]


def test_the_stream_keeps_its_rate_under_a_flood_on_every_key(rig: Rig) -> None:
    rows = []
    for stage, key in targets(rig):
        flood_rate, before, during = flood(rig, stage, key, FLOOD_RATE)
        rows.append((stage, flood_rate, before, during))
    _print(rows)
    for stage, _, before, during in rows:
        assert during >= KEPT * before, f"{stage} flood: {during:.1f}/s against {before:.1f}/s"
    report = check_motion(rig.record, load_profile("paper16"))
    print(report.summary())
    assert report.over == [], report.over[:5]


def test_a_flood_at_full_speed_breaks_nothing(rig: Rig) -> None:
    rows = [(stage, *flood(rig, stage, key, 0)) for stage, key in targets(rig)]
    _print(rows)
    report = check_motion(rig.record, load_profile("paper16"))
    print(report.summary())
    assert report.over == [], report.over[:5]
    assert all(p.poll() is None for p in rig.live.values())


def _print(rows: list[tuple[str, float, float, float]]) -> None:
    print()
    for stage, flood_rate, before, during in rows:
        print(
            f"flood on {stage:<15}: {flood_rate:>8.0f} msg/s for {FLOOD_S:.0f} s; commands "
            f"{during:5.1f}/s during it, {before:5.1f}/s before ({during / before:.0%})"
        )
