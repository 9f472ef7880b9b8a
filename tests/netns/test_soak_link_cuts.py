"""The soak with link cuts (``python -m tools.soak --link-cuts``): C on the board namespace,
its link taken down for 4 s as one of the faults in turn.

Runs the soak for 45 s after the chain streams, a fault every 12 s (a cut, a stall, a cut...),
and checks that the cuts show in its report: each one a fault, a gap in the commands at least
as long as most of the cut, no process dead on its own, no servo too fast, and the namespaces
gone afterwards.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from netns_hosts import require_root_and_tools

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
