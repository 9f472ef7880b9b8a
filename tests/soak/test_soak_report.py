"""A soak's report from its figures (tools/soak/report.py): every section, as JSON and lines."""

from __future__ import annotations

import json
from pathlib import Path

from motion_check import MotionReport

from facesynth.services.control.drivers.record import RecordLine
from tools.soak.commands import gaps, stale
from tools.soak.report import SECTIONS, Exit, SoakResult, as_json, summary, write
from tools.soak.rss import Incarnation, Sample, process_figures
from tools.soak.schedule import Fault

S = 1_000_000_000
T0 = 1_800_000_000 * S


def command(t_s: float, latency_s: float = 0.02) -> RecordLine:
    sent = T0 + round(t_s * S)
    return RecordLine(
        seq=0, frame=1, t_capture_ns=sent - round(latency_s * S), t_sent_ns=sent, face=True,
        servos={"jaw": 1500.0},
    )  # fmt: skip


def result() -> SoakResult:
    faults = [
        Fault("kill", "router", T0 + 60 * S, T0 + 63 * S, "pid 1 killed, pid 2 ready"),
        Fault("stall", "points", T0 + 120 * S, T0 + 123 * S),
    ]
    lines = [command(t / 10) for t in range(600)] + [command(66.0)]
    lines += [command(123.1, latency_s=3.0)] + [command(124 + t / 10) for t in range(10)]
    router = [
        Incarnation("router", 1, [Sample(t * 10.0, 60 + (10 if t > 20 else 0)) for t in range(6)])
    ]
    router.append(
        Incarnation("router", 2, [Sample(70 + t * 10.0, 50.0 + t / 36) for t in range(40)])
    )
    return SoakResult(
        started_ns=T0,
        ended_ns=T0 + 500 * S,
        options={"hours": 0.14, "interval": 60.0},
        faults=faults,
        rss=[process_figures("router", router), process_figures("control", [])],
        motion=MotionReport(steps=1200, worst_ratio=0.77, worst="jaw 77 µs in 33.3 ms", sessions=2),
        stale=stale(lines, faults, 0.25),
        gaps=gaps(lines, faults),
        executed=(len(lines), 3),
        died=[Exit("features", 99, -6, T0 + 130 * S, "FATAL: exception not rethrown")],
        stopped={"router": 0, "points": -6},
        log_findings={"points-1": ["FATAL: exception not rethrown"], "sensor-1": []},
    )


def test_the_json_has_every_section_and_the_figures() -> None:
    report = json.loads(json.dumps(as_json(result())))
    assert tuple(report) == SECTIONS
    assert report["faults"]["by_kind"] == {"kill": 1, "stall": 1}
    assert report["faults"]["list"][0] == {
        "kind": "kill", "target": "router", "t_s": 60.0, "took_s": 3.0,
        "detail": "pid 1 killed, pid 2 ready",
    }  # fmt: skip
    router = report["rss"]["router"]
    assert [inc["pid"] for inc in router["incarnations"]] == [1, 2]
    assert router["slope"]["mb_per_hour"] == 10.0  # the second incarnation: 1/36 MB per 10 s
    assert report["rss"]["control"] == {"steps": [], "slope": None, "hours": [], "incarnations": []}
    assert report["motion"]["worst_ratio"] == 0.77
    assert report["stale"]["count"] == 1
    assert report["stale"]["listed"][0]["after"] == "stall"
    assert report["gaps"]["kill"] == {"longest_s": 6.1, "at_s": 59.9, "target": "router"}
    assert report["exits"]["died"][0]["code"] == -6
    assert report["exits"]["log_findings"] == {"points-1": ["FATAL: exception not rethrown"]}
    assert report["run"]["hours"] == round(500 / 3600, 4)


def test_the_printed_lines_say_each_section() -> None:
    text = "\n".join(summary(result()))
    assert "2 faults (kill 1, stall 1)" in text
    assert "router" in text and "+10.00 MB/h" in text and "control    no samples" in text
    assert "largest step: 0.77 of its limit" in text
    assert "stale commands: 1 of" in text and "after stall: 1" in text
    assert "kill 6100 ms (router)" in text
    assert "features (code -6)" in text and "points exit -6" in text
    assert "points-1: 1 log line(s)" in text


def test_the_report_is_written_whole(tmp_path: Path) -> None:
    path = write(result(), tmp_path / "runs" / "soak.json")
    assert json.loads(path.read_text())["faults"]["count"] == 2
    assert [p.name for p in path.parent.iterdir()] == ["soak.json"]  # no temporary file left
