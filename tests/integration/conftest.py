"""Fixtures for tests that start facesynth services as separate OS processes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest


class Spawner:
    """Starts ``python -m facesynth ARGS`` processes, each logging to ``<name>.log``."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.procs: list[subprocess.Popen[bytes]] = []

    def __call__(self, *args: str, name: str) -> subprocess.Popen[bytes]:
        with open(self.folder / f"{name}.log", "wb") as log:
            proc = subprocess.Popen(
                [sys.executable, "-m", "facesynth", *args],
                stdout=log,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        self.procs.append(proc)
        return proc

    def log(self, name: str) -> str:
        """What a spawned process printed so far."""
        return (self.folder / f"{name}.log").read_text(errors="replace")


@pytest.fixture
def spawn(tmp_path: Path) -> Iterator[Spawner]:
    """A :class:`Spawner`; its processes are stopped (SIGTERM, then SIGKILL) at the end."""
    spawner = Spawner(tmp_path)
    yield spawner
    procs = spawner.procs
    for proc in procs:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
    for proc in procs:
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
