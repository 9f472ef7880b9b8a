"""A rig of real processes on a loopback router, for the fault suites (marker ``faults``).

:class:`Rig` starts the router and the five services (the OpenFace sample replayed in a loop at
30 fps, commands recorded by the ``record`` driver with paper16) and can kill any of them with
SIGKILL and start it again with the same arguments.
"""

from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from facesynth_processes import Processes, free_port

from facesynth.app.data import sample_openface_csv
from facesynth.services.control.drivers.record import RecordLine, read_record

#: What each process says once it listens (the line its readiness is taken from).
READY = {
    "router": "listening on",
    "control": "control interface on",
    "translator": "translator on",
    "features": "feature processor on",
    "points": "point streamer on",
    "sensor": "sensor: ticks",
}
ORDER = ("router", "control", "translator", "features", "points", "sensor")


@dataclass
class Rig:
    """The processes of one rig; ``record`` is the control interface's record file."""

    processes: Processes
    folder: Path
    rig: str = "faults"
    router: str = field(default_factory=lambda: f"tcp/127.0.0.1:{free_port()}")
    live: dict[str, subprocess.Popen[bytes]] = field(default_factory=dict)
    starts: dict[str, int] = field(default_factory=dict)

    @property
    def record(self) -> Path:
        return self.folder / "commands.jsonl"

    def args(self, name: str) -> list[str]:
        if name == "router":
            return ["router", "--listen", self.router]
        common = ["--connect", self.router, "--rig", self.rig, "--stats-interval", "0.5"]
        return {
            "control": ["control", "--profile", "paper16", "--out", str(self.record), *common],
            "translator": ["translator", "--profile", "paper16", *common],
            "features": ["features", *common],
            "points": [
                "points", "--openface-csv", str(sample_openface_csv()), "--loop-replay", *common
            ],
            "sensor": [
                "sensor", "--ticks", "1000000", "--fps", "30",
                "--wait-for", "points,features,translator,control", *common,
            ],
        }[name]  # fmt: skip

    def ready_line(self, name: str) -> str:
        """What ``name`` says once it listens."""
        return READY[name]

    def log_name(self, name: str) -> str:
        return f"{name}-{self.starts.get(name, 0)}"

    def start(self, name: str) -> float:
        """Start ``name`` (again); return the monotonic time it said it was ready."""
        self.starts[name] = self.starts.get(name, 0) + 1
        log = self.log_name(name)
        self.live[name] = self.processes.start(*self.args(name), name=log)
        self.processes.wait_for_line(log, self.ready_line(name), timeout=60)
        return time.monotonic()

    def kill(self, name: str) -> None:
        """SIGKILL: no clean-up, no return to neutral, nothing flushed but what already was."""
        proc = self.live[name]
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)

    def others_alive(self, but: str) -> list[str]:
        """Names of processes other than ``but`` that have exited."""
        return [n for n, p in self.live.items() if n != but and p.poll() is not None]

    def lines(self) -> list[RecordLine]:
        return read_record(self.record) if self.record.exists() else []

    def commands_after(self, t_wall_ns: int) -> list[RecordLine]:
        return [
            line for line in self.lines() if line.frame is not None and line.t_sent_ns > t_wall_ns
        ]

    def wait_for_commands(self, after_wall_ns: int, count: int, timeout: float) -> list[RecordLine]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            found = self.commands_after(after_wall_ns)
            if len(found) >= count:
                return found
            time.sleep(0.02)
        raise AssertionError(
            f"fewer than {count} commands within {timeout} s; control said:\n"
            + self.processes.log(self.log_name("control"))[-3000:]
        )


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[Rig]:
    processes = Processes(tmp_path)
    rig = Rig(processes, tmp_path)
    try:
        for name in ORDER:
            rig.start(name)
        rig.wait_for_commands(0, 60, timeout=60)
        yield rig
    finally:
        processes.stop()
