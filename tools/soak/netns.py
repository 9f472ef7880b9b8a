"""Link cuts for the soak (``--link-cuts``; root): C on another "host", its link cut and restored.

The separate-hosts suite's namespaces (tests/netns/netns_hosts.py, :class:`Hosts`): the router
and S, P, F, T on the "tracker" host, C on the "board", joined through an IP router namespace
whose link to the board :meth:`Hosts.link_down` takes down. Every process, the flooder and the
big-message sender included, runs under ``ip netns exec``; their pids are the programs' own, so
signals and RSS work as on loopback. Each side uses the shipped Zenoh settings (deploy/: the
router's, the services', the board client's lease and keep-alive), as the suite does.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from facesynth_processes import Processes
from netns_hosts import TRACKER_IP, Hosts

from tools.soak import ROOT

DEPLOY = ROOT / "deploy"
#: Where the router listens on the tracker host.
ROUTER = f"tcp/{TRACKER_IP}:7447"


def missing() -> str | None:
    """Why link cuts cannot run here (``None``: they can)."""
    if os.geteuid() != 0:
        return "--link-cuts needs root (network namespaces)"
    absent = [tool for tool in ("ip", "iptables") if shutil.which(tool) is None]
    return f"--link-cuts needs {', '.join(absent)} (iproute2, iptables)" if absent else None


def zenoh_config(process: str) -> list[str]:
    """The shipped Zenoh settings for ``process`` on its host."""
    name = {"router": "zenoh-router", "control": "zenoh-client"}.get(process, "zenoh-service")
    return ["--zenoh-config", str(DEPLOY / f"{name}.json5")]


class NsProcesses(Processes):
    """Starts each facesynth process on its host: control on the board, the rest on the
    tracker."""

    def __init__(self, folder: Path, hosts: Hosts) -> None:
        super().__init__(folder)
        self.hosts = hosts

    def start(self, *args: str, name: str, prefix: tuple[str, ...] = ()) -> subprocess.Popen[bytes]:
        host = self.hosts.board if args[0] == "control" else self.hosts.tracker
        return super().start(*args, name=name, prefix=("ip", "netns", "exec", host, *prefix))

    def on_tracker(self) -> tuple[str, ...]:
        """The prefix that runs a command on the tracker host (the flooder's, the sender's)."""
        return ("ip", "netns", "exec", self.hosts.tracker)
