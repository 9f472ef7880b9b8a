"""Whose wall clock a stamp is read on: the name every process on one kernel stamps under.

A message names the clock of its stamps (``capture_host`` for ``t_capture_ns``,
``sender_host`` for ``sent_ns``), and a receiver ages a stamp exactly when it names the
receiver's own clock (:mod:`facesynth.runtime.capture_age`). Its *own* clock is the kernel's
wall clock (``CLOCK_REALTIME``), which no namespace separates: containers (with hostnames of
their own), network namespaces and even time namespaces (which shift only the monotonic and
boot clocks) all read the one clock of the kernel they run on. So the name is the kernel's, not
the host name's:

* ``boot:<12 hex digits>``: the start of the kernel's boot id
  (``/proc/sys/kernel/random/boot_id``, a random UUID drawn at each boot). Every process and
  container on one running kernel reads the same one (checked under Podman 4.3 here: two
  containers with hostnames of their own read the host's boot id), and another machine, or the
  same one after a reboot, draws another (48 bits: two machines share one with a chance of
  4e-15). Only a virtual machine cloned while running, memory and all, keeps its
  original's boot id with a clock of its own.
* the host name, where there is no boot id to read (macOS, Windows), as before this rule:
  processes of one such host share it.

Both forms differ from the names of clocks that are not a host's (``ros2:<topic>``, a ROS 2
camera's stamps: :mod:`facesynth.services.sensor.sources.ros2`): host names have no colon.
"""

from __future__ import annotations

import functools
import re
import socket
from pathlib import Path
from typing import Final

#: Where Linux tells the running kernel's boot id.
BOOT_ID: Final = Path("/proc/sys/kernel/random/boot_id")
#: How many hex digits of the boot id name the clock.
DIGITS: Final = 12
_UUID = re.compile(r"[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}")


def clock_name(boot_id: str | None, hostname: str) -> str:
    """The name of the clock of a kernel whose boot id is ``boot_id`` (``None``: none could be
    read) on a host called ``hostname``; the host name only without a valid boot id."""
    text = (boot_id or "").strip().lower()
    if _UUID.fullmatch(text):
        return "boot:" + text.replace("-", "")[:DIGITS]
    return hostname or "host"


def read_boot_id(path: Path = BOOT_ID) -> str | None:
    """The kernel's boot id, or ``None`` where there is none to read."""
    try:
        return path.read_text(encoding="ascii", errors="replace")
    except OSError:
        return None


@functools.cache
def clock_host() -> str:
    """This process's clock name (see the module doc): what its stamps name as their host, and
    what it takes as its own when it ages others' stamps. Read once per process."""
    return clock_name(read_boot_id(), socket.gethostname())
