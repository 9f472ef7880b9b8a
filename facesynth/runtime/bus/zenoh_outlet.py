"""One key's Zenoh publisher, and whether a subscriber of another session matches it.

A Zenoh bus hands a message to Zenoh only while someone elsewhere listens: the publisher's
matching status, followed by a matching listener (on Zenoh's thread), says so; a message
published in the process then skips msgpack and ``put`` altogether when nobody elsewhere
listens (:meth:`facesynth.runtime.bus.zenoh_bus.ZenohBus.publish_message`).
"""

from __future__ import annotations

import contextlib
import threading
import time
from typing import Any, Final

import zenoh

#: Every facesynth publication's priority: one above Zenoh's default (see :class:`Outlet`).
PRIORITY = zenoh.Priority.DATA_HIGH


#: How long a new publisher hands Zenoh every message whatever its matching status says:
#: a session learns the subscribers of a key from its router in a round trip after declaring
#: the publisher (1-4 ms measured on loopback, client and peer), and a message sent meanwhile
#: must not be lost to a subscriber that was already there.
MATCH_GRACE_S: Final = 0.5


class Outlet:
    """One key's Zenoh publisher towards other sessions, and whether any subscriber of another
    session matches it now (kept by Zenoh's matching listener, on Zenoh's thread; during the
    first :data:`MATCH_GRACE_S` after its declaration, assumed)."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        # DROP, not BLOCK: a stopped subscriber must not stall this service or the rig (see
        # Bus). Not express: Zenoh's adaptive batching adds no latency on an idle link and
        # keeps a burst in few batches (express + DROP lost messages of bursts, measured).
        # DATA_HIGH: a link's queue is per priority, so a publisher flooding at Zenoh's
        # default priority (DATA) does not crowd the rig's own messages out of it.
        # Other sessions only: this session's subscriptions get it directly (ZenohBus.publish).
        self.publisher: Any = session.declare_publisher(
            key,
            congestion_control=zenoh.CongestionControl.DROP,
            express=False,
            priority=PRIORITY,
            allowed_destination=zenoh.Locality.REMOTE,
        )
        self._lock = threading.Lock()
        self._heard = False  # the listener spoke: its word beats the first reading
        self.matching = False
        self._settled_ns: int | None = time.monotonic_ns() + round(MATCH_GRACE_S * 1e9)
        self._listener: Any = self.publisher.declare_matching_listener(self._on_matching)
        status = _matching(self.publisher.matching_status)
        with self._lock:
            if not self._heard:
                self.matching = status

    def wanted(self) -> bool:
        """Whether a message must be handed to Zenoh now (a subscriber elsewhere matches)."""
        if self.matching:
            return True
        settled = self._settled_ns
        if settled is None:
            return False
        if time.monotonic_ns() < settled:
            return True
        self._settled_ns = None
        return False

    def _on_matching(self, status: Any) -> None:
        with self._lock:
            self._heard = True
            self.matching = _matching(status)

    def close(self) -> None:
        for entity in (self._listener, self.publisher):
            with contextlib.suppress(Exception):  # the session is already closed
                entity.undeclare()


def _matching(status: Any) -> bool:
    """Whether a ``zenoh.MatchingStatus`` says subscribers match (its stub says a bool)."""
    return bool(getattr(status, "matching", status))
