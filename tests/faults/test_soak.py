"""The soak itself, short: ``python -m tools.soak`` for a minute with a fault every 10 s.

The real thing (``make soak HOURS=N``) runs for hours; this runs it for 45 s after the chain
streams, which takes a kill -9 (of the translator, restarted), a stall of points, a flood and
an oversized burst, then checks that its JSON report has every section, that the kill shows in
it (the fault, the killed process's two incarnations in the RSS figures, the gap it made), that
no other process died, and that no servo stepped faster than its limit.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.faults, pytest.mark.timeout(240)]

ROOT = Path(__file__).resolve().parents[2]
SECTIONS = ("run", "faults", "commands", "rss", "motion", "stale", "gaps", "exits")


def test_a_short_soak_reports_every_section_and_its_kill(tmp_path: Path) -> None:
    out = tmp_path / "soak.json"
    done = subprocess.run(
        [sys.executable, "-m", "tools.soak", "--hours", str(45 / 3600), "--interval", "10",
         "--progress-every", "30", "--folder", str(tmp_path / "run"), "--out", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=200,
    )  # fmt: skip
    print(done.stdout[-4000:])
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(out.read_text())
    assert tuple(report) == SECTIONS
    kinds = [fault["kind"] for fault in report["faults"]["list"]]
    assert kinds[:4] == ["kill", "stall", "flood", "oversized"], kinds
    kill = report["faults"]["list"][0]
    killed = kill["target"]
    assert "killed" in kill["detail"] and "ready" in kill["detail"]
    pids = [inc["pid"] for inc in report["rss"][killed]["incarnations"]]
    assert len(pids) == 2 and pids[0] != pids[1], report["rss"][killed]
    assert str(pids[0]) in kill["detail"] and str(pids[1]) in kill["detail"]
    assert report["gaps"]["kill"]["target"] == killed
    assert report["gaps"]["kill"]["longest_s"] > 1.0  # the killed stage was gone for a second
    assert set(report["rss"]) == {"router", "control", "translator", "features", "points", "sensor"}
    assert report["commands"]["following_frames"] > 500
    assert report["stale"]["checked"] > 500
    assert report["motion"]["over"] == 0, report["motion"]["over_listed"]
    assert report["exits"]["died"] == [], report["exits"]["died"]
    assert "soak: report" in done.stdout and "largest step:" in done.stdout
