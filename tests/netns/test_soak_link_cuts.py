"""The soak with link cuts (``python -m tools.soak --link-cuts``): C on the board namespace,
its link taken down for 4 s as one of the faults in turn.

Runs the soak for 45 s after the chain streams, a fault every 12 s (a cut, a stall, a cut...),
and checks that the cuts show in its report: each one a fault, a gap in the commands at least
as long as most of the cut, no process dead on its own, no servo too fast, and the namespaces
gone afterwards. And SIGTERM in the middle of a cut: the link up again, the soak ended within
seconds, its report marked, no namespace or process of its session left.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

from netns_hosts import require_root_and_tools
from soak_interrupt import interrupt_soak

ROOT = Path(__file__).resolve().parents[2]


def test_the_soak_cuts_the_boards_link_and_reports_it(tmp_path: Path) -> None:
    require_root_and_tools()
    before = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    out = tmp_path / "soak.json"
    done = subprocess.run(
        [sys.executable, "-m", "tools.soak", "--link-cuts", "--kinds", "cut,stall",
         "--hours", str(45 / 3600), "--interval", "12", "--progress-every", "30",
         "--folder", str(tmp_path / "run"), "--out", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    print(done.stdout[-3000:])
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(out.read_text())
    cuts = [f for f in report["faults"]["list"] if f["kind"] == "cut"]
    assert len(cuts) >= 2 and all(f["detail"] == "board link down 4 s" for f in cuts), cuts
    assert report["gaps"]["cut"]["longest_s"] > 3.0, report["gaps"]
    assert report["exits"]["died"] == [], report["exits"]["died"]
    assert report["motion"]["over"] == 0, report["motion"]["over_listed"]
    after = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    assert after == before, "the soak left network namespaces behind"


def _namespaces() -> set[str]:
    listed = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    return {line.split()[0] for line in listed.splitlines() if line.strip()}


def _link_up(namespace: str, link: str) -> bool:
    shown = subprocess.run(
        ["ip", "-n", namespace, "-o", "link", "show", link], capture_output=True, text=True
    ).stdout
    return "UP" in shown.split("<", 1)[-1].split(">", 1)[0].split(",")


def test_sigterm_mid_cut_ends_the_soak_at_once_and_leaves_no_namespace(tmp_path: Path) -> None:
    require_root_and_tools()
    before = _namespaces()
    out, log = tmp_path / "soak.json", tmp_path / "soak.out"

    def cut(_leader: int) -> bool:  # the cut: the board's link down for 4 s
        (iprouter,) = [ns for ns in _namespaces() - before if ns.endswith("-iprouter")]
        return not _link_up(iprouter, "toboard")

    ended = interrupt_soak(
        [sys.executable, "-m", "tools.soak", "--link-cuts", "--kinds", "cut",
         "--hours", "1", "--interval", "5", "--source", "replay",
         "--folder", str(tmp_path / "run"), "--out", str(out)],
        log, cut, signal.SIGTERM, deadline_s=120,
    )  # fmt: skip
    code, took, printed = ended.code, ended.took_s, ended.printed
    assert code == 143, printed[-3000:]
    assert took < 15, took
    assert "the fault under way undone: board link up" in printed
    assert _namespaces() - before == set(), "the soak left network namespaces behind"
    stray = subprocess.run(["pgrep", "-s", str(ended.pid)], capture_output=True, text=True).stdout
    assert stray == "", stray
    report = json.loads(out.read_text())
    assert report["run"]["ended_early"] == "SIGTERM"
    last = report["faults"]["list"][-1]
    assert (last["kind"], last["detail"]) == ("cut", "cut short: Interrupted SIGTERM"), last
