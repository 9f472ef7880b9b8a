"""Whether a service is connected to its Zenoh router: transport events in, log lines out.

:class:`RouterLink` is pure: it is told when a transport to a router opens or closes, with the
time as data, and says what to log and how the link has fared (losses, time offline). The Zenoh
bus feeds it from Zenoh's transport events; services publish its figures in their stats, and
``facesynth status`` shows them.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class LinkFigures:
    """How a session's link to its routers has fared since it started."""

    #: Connected to at least one router now.
    connected: bool
    #: Times the last router was lost.
    losses: int
    #: Seconds spent without a router after the first connection (the current outage included).
    offline_s: float
    #: Seconds since the current outage began (0 while connected).
    down_for_s: float


def short_id(zid: str) -> str:
    """The first 8 hex digits of a Zenoh id: enough to tell routers apart in a log line."""
    return zid[:8]


class RouterLink:
    """Follows the routers a session is connected to; thread-safe (events come from Zenoh)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._routers: set[str] = set()
        self._losses = 0
        self._offline_ns = 0
        self._down_since_ns: int | None = None
        self._ever_connected = False

    def opened(self, zid: str, now_ns: int) -> str | None:
        """A transport to router ``zid`` opened; returns the line to log, if any."""
        with self._lock:
            was_connected = bool(self._routers)
            self._routers.add(zid)
            if was_connected:
                return f"also connected to router {short_id(zid)}"
            if not self._ever_connected:
                self._ever_connected = True
                return f"connected to router {short_id(zid)}"
            assert self._down_since_ns is not None
            outage = max(0, now_ns - self._down_since_ns)
            self._offline_ns += outage
            self._down_since_ns = None
            return (
                f"router {short_id(zid)} regained after {outage / 1e9:.1f} s without a router "
                f"(lost {self._losses} time{'s' if self._losses != 1 else ''} so far)"
            )

    def closed(self, zid: str, now_ns: int) -> str | None:
        """A transport to router ``zid`` closed; returns the line to log, if any."""
        with self._lock:
            if zid not in self._routers:
                return None
            self._routers.discard(zid)
            if self._routers:
                return f"lost router {short_id(zid)}; still connected to another"
            self._losses += 1
            self._down_since_ns = now_ns
            return (
                f"lost router {short_id(zid)}: no router now, nothing is sent or received "
                f"until it is back (reconnecting)"
            )

    def figures(self, now_ns: int) -> LinkFigures:
        """The link's figures at ``now_ns``."""
        with self._lock:
            down_for = 0 if self._down_since_ns is None else max(0, now_ns - self._down_since_ns)
            return LinkFigures(
                connected=bool(self._routers),
                losses=self._losses,
                offline_s=(self._offline_ns + down_for) / 1e9,
                down_for_s=down_for / 1e9,
            )
