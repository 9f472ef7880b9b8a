"""The processes of a multi-process benchmark: a loopback router, facesynth nodes, their CPU time.

CPU time is read from ``/proc/<pid>/stat`` (``utime + stime``, every thread of the process), so
it counts what Zenoh's threads, the event loop and the inference runtime spend alike; a
:class:`CpuWindow` takes it at the start and the end of a benchmark's steady state and divides
by the frames that went through in between.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

#: Clock ticks per second of ``/proc/<pid>/stat``'s times.
TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


class ProcessStartError(RuntimeError):
    """A benchmark process that did not start (its log is in the message)."""


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds used so far by every thread of process ``pid``; ``None`` when
    it is gone or ``/proc`` cannot be read."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as handle:
            text = handle.read()
    except OSError:
        return None
    # The command name (field 2) may hold spaces and parentheses: split after its last ')'.
    fields = text.rpartition(")")[2].split()
    try:
        return (int(fields[11]) + int(fields[12])) / TICKS
    except (IndexError, ValueError):
        return None


@dataclass
class CpuWindow:
    """CPU seconds of named processes between :meth:`start` and :meth:`stop`."""

    pids: Mapping[str, int]
    started: dict[str, float] = field(default_factory=dict)
    used: dict[str, float] = field(default_factory=dict)
    t_start: float = 0.0
    seconds: float = 0.0

    def start(self) -> None:
        """Take the first reading."""
        self.t_start = time.monotonic()
        self.started = {
            name: cpu for name, pid in self.pids.items() if (cpu := cpu_seconds(pid)) is not None
        }

    def stop(self) -> None:
        """Take the second reading; processes gone meanwhile are left out."""
        self.seconds = time.monotonic() - self.t_start
        self.used = {}
        for name, before in self.started.items():
            after = cpu_seconds(self.pids[name])
            if after is not None:
                self.used[name] = after - before

    def per_frame_ms(self, frames: int) -> dict[str, float]:
        """Milliseconds of CPU per frame of each process over the window."""
        if frames <= 0:
            return {}
        return {name: used * 1e3 / frames for name, used in self.used.items()}


class ProcessGroup:
    """A router and facesynth commands started as child processes; all stopped on exit.

    With ``source``, the processes run the facesynth of that source tree (a checkout of
    another version, put first on ``PYTHONPATH``) instead of this one, for before/after
    comparisons in one benchmark run.
    """

    def __init__(self, folder: Path, source: str | None = None) -> None:
        self.folder = folder
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self.locator = ""
        self.env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        #: ``-P``: no current directory first on ``sys.path``, which would shadow ``source``
        #: with the tree the benchmark was started from.
        self.python = [sys.executable, "-P"] if source else [sys.executable]
        if source:
            self.env["PYTHONPATH"] = os.pathsep.join(
                [source, *filter(None, [os.environ.get("PYTHONPATH")])]
            )

    def start(self, name: str, *args: str) -> subprocess.Popen[bytes]:
        """Start ``python -m facesynth ARGS`` with its output in ``<folder>/<name>.log``."""
        with open(self.log(name), "wb") as out:
            proc = subprocess.Popen(
                [*self.python, "-m", "facesynth", *args],
                stdout=out,
                stderr=subprocess.STDOUT,
                env=self.env,
            )
        self.procs[name] = proc
        return proc

    def log(self, name: str) -> Path:
        """The log file of a process."""
        return self.folder / f"{name}.log"

    def start_router(self, *args: str, timeout: float = 15.0) -> str:
        """Start ``facesynth router ARGS`` on a free loopback port; return its locator."""
        proc = self.start("router", "router", "--listen", "tcp/127.0.0.1:0", *args)
        log = self.log("router")
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            match = re.search(r"listening on (tcp/[0-9.]+:\d+)", log.read_text(errors="replace"))
            if match:
                self.locator = match.group(1)
                return self.locator
            if proc.poll() is not None:
                break
            time.sleep(0.05)
        raise ProcessStartError(f"the router did not start:\n{log.read_text(errors='replace')}")

    def pids(self) -> dict[str, int]:
        """Process ids by name."""
        return {name: proc.pid for name, proc in self.procs.items()}

    def failed(self, names: Iterable[str] | None = None) -> dict[str, str]:
        """Processes (of ``names``) that ended with an error, with the end of their log."""
        out = {}
        for name in names if names is not None else self.procs:
            proc = self.procs[name]
            if proc.poll() not in (None, 0):
                out[name] = self.log(name).read_text(errors="replace")[-3000:]
        return out

    def stop(self, names: Iterable[str], timeout: float = 15.0) -> None:
        """SIGTERM these processes and wait for them (killed after ``timeout``)."""
        chosen = [self.procs[name] for name in names]
        for proc in chosen:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + timeout
        for proc in chosen:
            try:
                proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()

    def close(self) -> None:
        """Kill whatever still runs."""
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait()
