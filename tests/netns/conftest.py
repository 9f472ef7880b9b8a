"""Fixtures for the separate-hosts tests (marked ``netns``; ``make test-netns``; root)."""

from __future__ import annotations

import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from facesynth_processes import Processes
from netns_hosts import Hosts, as_host, require_root_and_tools


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if Path(str(item.fspath)).is_relative_to(Path(__file__).parent):
            item.add_marker(pytest.mark.netns)
            item.add_marker(pytest.mark.timeout(600))


class NsSpawner(Processes):
    """Starts ``python -m facesynth ARGS`` inside a namespace, under the host name ``name`` (as a
    container of that name), logging to ``<name>.log``."""

    def __call__(self, ns: str, *args: str, name: str) -> subprocess.Popen[bytes]:  # type: ignore[override]
        return self.start(*args, name=name, prefix=as_host(ns, name))

    stop_all = Processes.stop


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
