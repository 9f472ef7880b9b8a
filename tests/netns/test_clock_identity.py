"""Processes on one machine with host names and networks of their own (as its containers have)
name one clock: the kernel's (``facesynth.runtime.clock_host``), so C ages their stamps as its
own, exactly, with no probation; the host names differ, as compose's containers' do."""

from __future__ import annotations

import subprocess
import sys

from netns_hosts import Hosts, as_host

from facesynth.runtime.clock_host import clock_host

SAYS = (
    "import socket; from facesynth.runtime.clock_host import clock_host; "
    "print(socket.gethostname(), clock_host())"
)


def test_processes_with_host_names_of_their_own_on_one_kernel_name_one_clock(
    hosts: Hosts,
) -> None:
    seen = {}
    for ns, name in ((hosts.tracker, "sensor"), (hosts.board, "control")):
        said = subprocess.run(
            [*as_host(ns, name), sys.executable, "-c", SAYS],
            capture_output=True,
            text=True,
            timeout=60,
            check=True,
        )
        hostname, clock = said.stdout.split()
        seen[hostname] = clock
    assert set(seen) == {"sensor", "control"}  # two host names, neither this machine's
    assert set(seen.values()) == {clock_host()}  # one kernel: one clock, named alike
