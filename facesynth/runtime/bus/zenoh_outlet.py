"""One key's Zenoh publisher, and whether a subscriber of another session matches it.

A Zenoh bus hands a message to Zenoh only while someone elsewhere listens: the publisher's
matching status, followed by a matching listener (on Zenoh's thread), says so; a message
published in the process then skips msgpack and ``put`` altogether when nobody elsewhere
listens (:meth:`facesynth.runtime.bus.zenoh_bus.ZenohBus.publish_message`).

The gate must never stay shut on a subscriber that is there (issue #28: in a soak, after the
sensor and points services lost their live router for 0.1 s and rejoined it, no frame reached
features for 57 s, until the next router change). Zenoh's listener runs each change as a task
of its own that reads the status again and says nothing when the status it reads differs from
the change it was started for (eclipse-zenoh 1.10, ``update_matching_status``), so a listener
can fall silent on a status that settled after it looked. Hence, besides the listener:

- while the gate is shut, the status is read again every :data:`RECHECK_S` as messages come;
- when the session gains a router again (:meth:`Outlet.regained`), every message is handed to
  Zenoh for :data:`MATCH_GRACE_S`, as for a new publisher, and the status is read right after;
- if the gate is still shut :data:`REDECLARE_S` after that, the publisher is declared anew
  once (a client's new publisher asks its router again who subscribes);
- each change of the gate is logged, one line (``facesynth.link``), with how many messages
  were held back while it was shut.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from typing import Any, Final

import zenoh

log = logging.getLogger("facesynth.link")

#: Every facesynth publication's priority: one above Zenoh's default (see :class:`Outlet`).
PRIORITY = zenoh.Priority.DATA_HIGH


#: How long a new publisher hands Zenoh every message whatever its matching status says:
#: a session learns the subscribers of a key from its router in a round trip after declaring
#: the publisher (1-4 ms measured on loopback, client and peer), and a message sent meanwhile
#: must not be lost to a subscriber that was already there.
MATCH_GRACE_S: Final = 0.5


#: While no subscriber matches, how often the matching status is read again (as messages
#: come), rather than trusting the listener alone; one read took 2-11 µs (client on loopback).
RECHECK_S: Final = 1.0

#: How long after the session regains a router a still shut gate has its publisher declared
#: anew (once per regain): a round trip to the router answers within milliseconds on loopback.
REDECLARE_S: Final = 2.0


class Outlet:
    """One key's Zenoh publisher towards other sessions, and whether any subscriber of another
    session matches it now (kept by Zenoh's matching listener, on Zenoh's thread, and read
    again while it says none; during the first :data:`MATCH_GRACE_S` after its declaration or
    a regained router, assumed)."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self.key = key
        self._session = session
        self._lock = threading.Lock()
        self.matching = False
        #: Messages not handed to Zenoh since the gate last shut (for the log line).
        self.held = 0
        self._shut_ns = time.monotonic_ns()
        self._ever_matched = False
        self._generation = 0
        self._redeclare_ns: int | None = None
        self._declare()

    def _declare(self) -> None:
        # DROP, not BLOCK: a stopped subscriber must not stall this service or the rig (see
        # Bus). Not express: Zenoh's adaptive batching adds no latency on an idle link and
        # keeps a burst in few batches (express + DROP lost messages of bursts, measured).
        # DATA_HIGH: a link's queue is per priority, so a publisher flooding at Zenoh's
        # default priority (DATA) does not crowd the rig's own messages out of it.
        # Other sessions only: this session's subscriptions get it directly (ZenohBus.publish).
        self.publisher: Any = self._session.declare_publisher(
            self.key,
            congestion_control=zenoh.CongestionControl.DROP,
            express=False,
            priority=PRIORITY,
            allowed_destination=zenoh.Locality.REMOTE,
        )
        with self._lock:
            self._generation += 1
            generation = self._generation
            self._heard = False  # the listener spoke: its word beats the first reading
        self._settled_ns: int | None = time.monotonic_ns() + round(MATCH_GRACE_S * 1e9)
        self._recheck_ns = self._settled_ns
        self._listener: Any = self.publisher.declare_matching_listener(
            lambda status: self._on_matching(status, generation)
        )
        status = _matching(self.publisher.matching_status)
        with self._lock:
            if not self._heard and generation == self._generation:
                self._set(status, "")

    def wanted(self) -> bool:
        """Whether a message must be handed to Zenoh now (a subscriber elsewhere matches);
        call from the publishing thread only."""
        if self.matching:
            return True
        now = time.monotonic_ns()
        settled = self._settled_ns
        if settled is not None:
            if now < settled:
                return True
            self._settled_ns = None
        if now >= self._recheck_ns and self._recheck(now):
            return True
        self.held += 1
        return False

    def regained(self) -> None:
        """The session has a router again (after none): hand Zenoh every message for
        :data:`MATCH_GRACE_S`, then read the status; any thread."""
        now = time.monotonic_ns()
        self._settled_ns = now + round(MATCH_GRACE_S * 1e9)
        self._recheck_ns = self._settled_ns
        self._redeclare_ns = now + round(REDECLARE_S * 1e9)

    def _recheck(self, now: int) -> bool:
        """Read the matching status again (the gate is shut); whether it opened."""
        self._recheck_ns = now + round(RECHECK_S * 1e9)
        try:
            status = _matching(self.publisher.matching_status)
        except Exception:  # the session is closing: nothing to hand over
            return False
        if status:
            with self._lock:
                self._set(True, " (read again: the matching listener had not said so)")
            return True
        due = self._redeclare_ns
        if due is not None and now >= due:
            self._redeclare_ns = None
            held = self.held
            self.declare_anew()
            log.log(
                # A key nobody ever listened to (stats without an observer) is no news.
                logging.INFO if self._ever_matched else logging.DEBUG,
                "publisher %s: no subscriber matches %.1f s after regaining the router "
                "(%s held back); declared it anew",
                self.key,
                REDECLARE_S,
                _messages(held),
            )
            return self.matching
        return False

    def _on_matching(self, status: Any, generation: int) -> None:
        with self._lock:
            if generation != self._generation:
                return  # a listener of a publisher declared anew since
            self._heard = True
            self._set(_matching(status), "")

    def _set(self, matching: bool, how: str) -> None:
        """The gate's new state, logged when it changes; under the lock."""
        if matching == self.matching:
            return
        self.matching = matching
        now = time.monotonic_ns()
        if matching:
            shut_s = (now - self._shut_ns) / 1e9
            level = logging.INFO if self._ever_matched or how else logging.DEBUG
            self._ever_matched = True
            self._redeclare_ns = None
            log.log(
                level,
                "publisher %s: a subscriber matches%s; %s held back over %.1f s without one",
                self.key,
                how,
                _messages(self.held),
                shut_s,
            )
        else:
            self._shut_ns = now
            self.held = 0
            self._recheck_ns = now + round(RECHECK_S * 1e9)
            log.info("publisher %s: no subscriber matches now; holding messages back", self.key)

    def declare_anew(self) -> None:
        """Undeclare the publisher and declare it again (its router lost it)."""
        self._undeclare()
        self._declare()

    def _undeclare(self) -> None:
        for entity in (self._listener, self.publisher):
            with contextlib.suppress(Exception):  # the session is already closed
                entity.undeclare()

    def close(self) -> None:
        self._undeclare()


def _messages(count: int) -> str:
    return f"{count:,} message{'s' if count != 1 else ''}"


def _matching(status: Any) -> bool:
    """Whether a ``zenoh.MatchingStatus`` says subscribers match (its stub says a bool)."""
    return bool(getattr(status, "matching", status))
