"""Fixtures for recording tests: facesynth commands as real OS processes."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest


class Processes:
    """Starts ``python -m facesynth ARGS``, each logging to ``<name>.log``."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.started: list[subprocess.Popen[bytes]] = []

    def start(self, *args: str, name: str) -> subprocess.Popen[bytes]:
        with open(self.folder / f"{name}.log", "wb") as log:
            proc = subprocess.Popen(
                [sys.executable, "-m", "facesynth", *args],
                stdout=log,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        self.started.append(proc)
        return proc

    def log(self, name: str) -> str:
        """What a process printed so far."""
        return (self.folder / f"{name}.log").read_text(errors="replace")

    def wait_for_line(self, name: str, text: str, timeout: float = 30.0) -> str:
        """The first line of a process's log containing ``text`` (fails after ``timeout``)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for line in self.log(name).splitlines():
                if text in line:
                    return line
            time.sleep(0.05)
        raise AssertionError(f"{name} never printed {text!r}; it printed:\n{self.log(name)}")


def free_port() -> int:
    """A TCP port free on loopback right now (for a router that must listen on a known port)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def run_facesynth(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """Run one facesynth command to its end."""
    return subprocess.run(
        [sys.executable, "-m", "facesynth", *args], capture_output=True, text=True, timeout=timeout
    )


@pytest.fixture
def processes(tmp_path: Path) -> Iterator[Processes]:
    """A :class:`Processes`; what is still running at the end gets SIGTERM, then SIGKILL."""
    spawner = Processes(tmp_path)
    yield spawner
    for proc in spawner.started:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
    for proc in spawner.started:
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
