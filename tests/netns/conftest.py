"""Fixtures for the separate-hosts tests (marked ``netns``; ``make test-netns``; root)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from netns_hosts import Hosts, require_root_and_tools


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if Path(str(item.fspath)).is_relative_to(Path(__file__).parent):
            item.add_marker(pytest.mark.netns)
            item.add_marker(pytest.mark.timeout(600))


class NsSpawner:
    """Starts ``python -m facesynth ARGS`` inside a namespace, logging to ``<name>.log``."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.procs: list[subprocess.Popen[bytes]] = []

    def __call__(self, ns: str, *args: str, name: str) -> subprocess.Popen[bytes]:
        with open(self.folder / f"{name}.log", "wb") as log:
            proc = subprocess.Popen(
                ["ip", "netns", "exec", ns, sys.executable, "-m", "facesynth", *args],
                stdout=log,
                stderr=subprocess.STDOUT,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        self.procs.append(proc)
        return proc

    def log(self, name: str) -> str:
        return (self.folder / f"{name}.log").read_text(errors="replace")

    def stop_all(self) -> None:
        for proc in self.procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in self.procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


@pytest.fixture
def hosts() -> Iterator[Hosts]:
    require_root_and_tools()
    made = Hosts()
    try:
        made.create()
        yield made
    finally:
        made.destroy()


@pytest.fixture
def ns_spawn(tmp_path: Path, hosts: Hosts) -> Iterator[NsSpawner]:
    spawner = NsSpawner(tmp_path)
    try:
        yield spawner
    finally:
        spawner.stop_all()
