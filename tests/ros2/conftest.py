"""Fixtures of the ROS 2 group (marked ``ros2``; ``make test-ros2``; root and the [ros2] extra).

Every test runs in a network namespace with only loopback (``make test-ros2`` starts pytest
under ``unshare -n``), and checks it: DDS discovery multicasts on every interface otherwise.
Each test also gets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and a ``ROS_DOMAIN_ID`` of its
own (or of its module's own, where the module's tests share one peer process), which the
processes it starts inherit. They fail, never skip, when any of this is missing.
"""

from __future__ import annotations

import fcntl
import importlib.util
import itertools
import os
import socket
import struct
from collections.abc import Iterator
from pathlib import Path

import pytest
from facesynth_processes import Processes

#: Domain ids handed to the tests, one each (Fast DDS takes 0-101 on Linux).
_DOMAINS = itertools.count(31)
IFF_UP = 0x1
SIOCGIFFLAGS = 0x8913


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if Path(str(item.fspath)).is_relative_to(Path(__file__).parent):
            item.add_marker(pytest.mark.ros2)
            item.add_marker(pytest.mark.timeout(600))


def interfaces() -> dict[str, bool]:
    """This network namespace's interfaces and whether each is up (asked of the kernel through
    a socket of this namespace: /sys/class/net may still show the host's)."""
    found = {}
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        for _, name in socket.if_nameindex():
            request = struct.pack("16sH14x", name.encode(), 0)
            flags = struct.unpack("16sH14x", fcntl.ioctl(probe, SIOCGIFFLAGS, request))[1]
            found[name] = bool(flags & IFF_UP)
    return found


def loopback_only_problem(seen: dict[str, bool]) -> str | None:
    """Why a namespace with ``seen`` interfaces is not one with only loopback, up (or None)."""
    others = sorted(name for name in seen if name != "lo")
    if others:
        return (
            f"the ROS 2 tests run in a network namespace with only loopback, and this one has "
            f"{', '.join(others)}: run them with make test-ros2 (unshare -n)"
        )
    if not seen.get("lo"):
        return "loopback is down in this namespace: ip link set lo up (make test-ros2 does)"
    return None


def enter_ros2_host(monkeypatch: pytest.MonkeyPatch, domain: int) -> int:
    """Check the namespace and the extra; set the discovery range and ``domain``; the domain."""
    problem = loopback_only_problem(interfaces())
    if problem:
        pytest.fail(problem)
    if importlib.util.find_spec("rclpy") is None:
        pytest.fail("the ROS 2 tests need the [ros2] extra: pip install -e '.[ros2]'")
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    assert os.environ["ROS_DOMAIN_ID"] == str(domain)
    return domain


@pytest.fixture
def ros2_domain() -> int:
    """The test's ``ROS_DOMAIN_ID``: one of its own."""
    return next(_DOMAINS)


@pytest.fixture(scope="module")
def ros2_module_host() -> Iterator[int]:
    """:func:`ros2_host` for a whole module, with one domain for all its tests: for a module
    whose tests share a ROS 2 peer started once (a module-scoped fixture taking this one, and
    ``ros2_domain`` overridden to return it). Its tests keep apart by topics of their own."""
    with pytest.MonkeyPatch.context() as monkeypatch:
        yield enter_ros2_host(monkeypatch, next(_DOMAINS))


@pytest.fixture(autouse=True)
def ros2_host(monkeypatch: pytest.MonkeyPatch, ros2_domain: int) -> int:
    """Check the namespace and the extra; set the discovery range and the test's domain
    (:func:`ros2_domain`); the domain id."""
    return enter_ros2_host(monkeypatch, ros2_domain)


@pytest.fixture
def procs(tmp_path: Path) -> Iterator[Processes]:
    spawner = Processes(tmp_path)
    try:
        yield spawner
    finally:
        spawner.stop()
