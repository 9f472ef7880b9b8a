"""The soak itself, short: ``python -m tools.soak`` for a minute with a fault every 10 s.

The real thing (``make soak HOURS=N``) runs for hours; this runs it for 45 s after the chain
streams, which takes a kill -9 (of the translator, restarted), a stall of points, a flood and
an oversized burst, then checks that its JSON report has every section, that the kill shows in
it (the fault, the killed process's two incarnations in the RSS figures, the gap it made), that
no other process died, and that no servo stepped faster than its limit.

Ctrl-C: a soak started with SIGINT ignored (as ``nohup ... &`` starts it) and sent SIGINT in the
middle of a stall ends within seconds, points continued, nothing of its session left, its
report written and marked ended early.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from soak_interrupt import interrupt_soak

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


def _session(leader: int) -> list[str]:
    """The processes still in ``leader``'s session (pid and command line)."""
    left = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            cmdline = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue  # gone meanwhile
        if int(fields[3]) == leader:
            left.append(f"{stat.parent.name} {cmdline}")
    return left


def _state(pid: int) -> str:
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]


def test_sigint_ends_a_soak_at_once_mid_stall_with_its_report(tmp_path: Path) -> None:
    # Started as a script starts it in the background (`nohup python -m tools.soak ... &`):
    # SIGINT inherited ignored, which Python leaves ignored unless the soak handles it itself.
    out, log = tmp_path / "soak.json", tmp_path / "soak.out"
    points: list[int] = []

    def stalled(leader: int) -> bool:  # the stall: points stopped (SIGSTOP) for 3 s
        if not points:
            points.extend(int(line.split()[0]) for line in _session(leader) if " points " in line)
            assert len(points) == 1, _session(leader)
        return _state(points[0]) == "T"

    ended = interrupt_soak(
        ["sh", "-c", 'trap "" INT; exec "$0" "$@"', sys.executable, "-m", "tools.soak",
         "--hours", "1", "--interval", "3", "--kinds", "stall", "--source", "replay",
         "--folder", str(tmp_path / "run"), "--out", str(out)],
        log, stalled, signal.SIGINT, deadline_s=90,
    )  # fmt: skip
    code, took, printed = ended.code, ended.took_s, ended.printed
    assert code == 130, printed[-3000:]
    assert took < 15, took  # not the hour, nor a stopped points' 10 s before its SIGKILL
    assert f"pid {points[0]} continued" in printed
    assert _session(ended.pid) == []
    report = json.loads(out.read_text())
    assert tuple(report) == SECTIONS
    assert report["run"]["ended_early"] == "SIGINT" and report["run"]["hours"] < 0.05
    last = report["faults"]["list"][-1]
    assert (last["kind"], last["detail"]) == ("stall", "cut short: Interrupted SIGINT"), last
    assert report["exits"]["stopped"]["points"] == 0, report["exits"]  # continued, then ended
    assert report["commands"]["following_frames"] > 0
    assert "ended early by SIGINT" in printed and "soak: report" in printed
