"""bench/rig_run.py's RigRun: the capture-to-command latencies of a run's control nodes."""

from __future__ import annotations

import pytest

from facesynth.app.bench.rig_run import RigRun
from facesynth.services.control.drivers.record import RecordLine

MS = 1_000_000


def _line(frame: int, latency_ms: float) -> RecordLine:
    t_capture = frame * 33 * MS
    return RecordLine(
        seq=frame,
        frame=frame,
        t_capture_ns=t_capture,
        t_sent_ns=t_capture + round(latency_ms * MS),
        face=True,
        servos={"jaw": 1500.0},
    )


def test_latencies_are_of_the_steady_window_unless_asked_for_every_frame() -> None:
    run = RigRun(records={"control": [_line(0, 40.0), _line(1, 30.0), _line(2, 9.5)]})
    run.steady_from = 1
    assert run.latencies_ms("control") == pytest.approx([30.0, 9.5])
    assert run.latencies_ms("control", steady=False) == pytest.approx([40.0, 30.0, 9.5])


def test_a_node_without_records_has_no_latencies() -> None:
    run = RigRun(records={"control": [_line(0, 12.0)]})
    assert run.latencies_ms("control_robot1") == []
