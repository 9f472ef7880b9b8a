"""Separate "hosts" on one machine: network namespaces joined through an IP router namespace.

::

    tracker (10.233.1.2) ── veth ── iprouter (10.233.1.1 | 10.233.2.1) ── veth ── board (10.233.2.2)

Addresses exist only inside the namespaces made here; nothing is sent anywhere else. The link
between the IP router and the board can be taken down (``ip link set down``) or made to drop
every packet silently (``iptables -j DROP`` in the router's FORWARD chain).

What separates these "hosts" is the network, and their names: each process started here runs
with a host name of its own (:func:`as_host`, a UTS namespace), as each container of a compose
file does. What they share is this machine's kernel, so its one wall clock: the services name
it alike (:func:`facesynth.runtime.clock_host.clock_host`, the kernel's boot id), and C ages the
tracker's capture stamps exactly, as its own clock's, with no probation, as on one machine.
Clocks that do differ (another machine's, a camera's) are the pure tests' of
``facesynth.runtime.capture_age`` and ``tests/faults/test_stale_commands.py``'s.
"""

from __future__ import annotations

import subprocess
import sys
import uuid
from dataclasses import dataclass, field

from host_requirements import require_root_and_tools as require

TRACKER_IP = "10.233.1.2"
BOARD_IP = "10.233.2.2"


#: Sets the host name of the UTS namespace ``unshare --uts`` made, then runs the rest (same pid).
_AS_HOST = (
    "import os, socket, sys; socket.sethostname(sys.argv[1]); os.execv(sys.argv[2], sys.argv[2:])"
)


def as_host(ns: str, hostname: str) -> tuple[str, ...]:
    """The prefix running a command in network namespace ``ns`` under a host name of its own,
    ``hostname`` (its own UTS namespace), as a container on this machine runs: another host by
    name and network, on this machine's kernel and clock."""
    return ("ip", "netns", "exec", ns, "unshare", "--uts", sys.executable, "-c", _AS_HOST, hostname)


def require_root_and_tools() -> None:
    """Fail (never skip) naming what is missing."""
    require("the separate-hosts tests", "netns", "create network namespaces")


def _ip(*args: str) -> None:
    result = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if result.returncode != 0:
        raise AssertionError(f"ip {' '.join(args)}: {result.stderr.strip()}")


@dataclass
class Hosts:
    """Three namespaces; ``tracker`` and ``board`` reach each other through ``iprouter``."""

    prefix: str = field(default_factory=lambda: f"fs{uuid.uuid4().hex[:6]}")

    @property
    def tracker(self) -> str:
        return f"{self.prefix}-tracker"

    @property
    def iprouter(self) -> str:
        return f"{self.prefix}-iprouter"

    @property
    def board(self) -> str:
        return f"{self.prefix}-board"

    #: The IP router's interface towards the board (the one a cut takes down).
    board_link = "toboard"

    def create(self) -> None:
        for ns in (self.tracker, self.iprouter, self.board):
            _ip("netns", "add", ns)
            _ip("-n", ns, "link", "set", "lo", "up")
        _ip(
            "link",
            "add",
            "name",
            "eth0tr",
            "netns",
            self.tracker,
            "type",
            "veth",
            "peer",
            "name",
            "totracker",
            "netns",
            self.iprouter,
        )
        _ip(
            "link",
            "add",
            "name",
            "eth0bd",
            "netns",
            self.board,
            "type",
            "veth",
            "peer",
            "name",
            self.board_link,
            "netns",
            self.iprouter,
        )
        for ns, dev, addr, gateway in (
            (self.tracker, "eth0tr", f"{TRACKER_IP}/24", "10.233.1.1"),
            (self.board, "eth0bd", f"{BOARD_IP}/24", "10.233.2.1"),
        ):
            _ip("-n", ns, "addr", "add", addr, "dev", dev)
            _ip("-n", ns, "link", "set", dev, "up")
            _ip("-n", ns, "route", "add", "default", "via", gateway)
        for dev, addr in (("totracker", "10.233.1.1/24"), (self.board_link, "10.233.2.1/24")):
            _ip("-n", self.iprouter, "addr", "add", addr, "dev", dev)
            _ip("-n", self.iprouter, "link", "set", dev, "up")
        self.run(self.iprouter, "sysctl", "-qw", "net.ipv4.ip_forward=1")

    def destroy(self) -> None:
        for ns in (self.tracker, self.iprouter, self.board):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)

    def run(self, ns: str, *argv: str) -> str:
        result = subprocess.run(
            ["ip", "netns", "exec", ns, *argv], capture_output=True, text=True, timeout=60
        )
        if result.returncode != 0:
            raise AssertionError(f"{' '.join(argv)} in {ns}: {result.stderr.strip()}")
        return result.stdout

    def link_down(self) -> None:
        _ip("-n", self.iprouter, "link", "set", self.board_link, "down")

    def link_up(self) -> None:
        _ip("-n", self.iprouter, "link", "set", self.board_link, "up")

    def drop_start(self) -> None:
        self.run(self.iprouter, "iptables", "-I", "FORWARD", "-j", "DROP")

    def drop_stop(self) -> None:
        self.run(self.iprouter, "iptables", "-D", "FORWARD", "-j", "DROP")

    def board_bytes(self) -> int:
        """Bytes through the board's interface so far, both directions."""
        stats = self.run(
            self.board,
            "cat",
            "/sys/class/net/eth0bd/statistics/rx_bytes",
            "/sys/class/net/eth0bd/statistics/tx_bytes",
        )
        return sum(int(v) for v in stats.split())
