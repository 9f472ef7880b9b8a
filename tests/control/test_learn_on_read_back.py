"""``facesynth learn --driver dynamixel`` against the emulated Dynamixel bus (Protocol 2.0,
sixteen XL430s that move at a finite speed and report where they are), the robot's camera being
the simulated head's MJPEG URL: every pose settles on the positions the servos read back (the
log says so, the summary counts them), and the session keeps those positions."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from facesynth_processes import Processes, run_facesynth
from fake_devices.dynamixel import FakeDynamixelBus

from facesynth.app.learn.session import read_session

pytestmark = pytest.mark.slow

POSES = 6


def test_learn_settles_on_the_positions_a_dynamixel_bus_reads_back(
    processes: Processes, tmp_path: Path
) -> None:
    link = str(tmp_path / "simhead-tty")
    camera = processes.start_simhead(link)
    bus = FakeDynamixelBus(tmp_path / "ttyDXL", list(range(1, 17)))
    bus.plug()
    session = tmp_path / "s.mcap"
    try:
        done = run_facesynth(
            "learn", "--profile", "paper16", "--driver", "dynamixel", "--port", str(bus.link),
            "--baud", "1000000", "--camera", camera, "--out", str(session),
            "--poses", str(POSES), "--no-fit", "--log-level", "INFO", timeout=240,
        )  # fmt: skip
    finally:
        bus.close()
    assert done.returncode == 0, done.stderr[-3000:]
    assert "poses settle on measured positions" in done.stderr
    summary: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    assert summary["taken"] == POSES and summary["reached"] == {"measured": POSES}, summary
    samples = read_session(session).samples
    assert [s.reached for s in samples] == ["measured"] * POSES
    for sample in samples:
        assert set(sample.measured) == set(sample.commanded)
        assert all(abs(sample.measured[n] - v) <= 20 for n, v in sample.commanded.items())
