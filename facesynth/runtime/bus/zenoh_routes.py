"""How one Zenoh session's samples reach its buses' mailboxes.

One Zenoh subscriber per key expression and session (a :class:`Feed`), however many mailboxes
(:class:`ZenohSubscription`) listen to it; each sample is screened per mailbox on Zenoh's thread
(size limit before the payload is copied, then the mailbox's screen), so refused payloads never
reach an event loop. A session's own publications skip Zenoh (``allowed_destination=REMOTE``)
and are delivered to its feeds directly (:meth:`SessionRoutes.targets`).

A feed that has heard nothing :data:`REDECLARE_S` after its session regained a router declares
its Zenoh subscriber anew, once per regain (issue #28: whatever left a rejoined session's
subscription unknown to its router, the new declaration tells it again).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from typing import Any, ClassVar

import zenoh

from facesynth.runtime.bus.base import Subscription
from facesynth.runtime.bus.sample import Sample
from facesynth.runtime.bus.zenoh_outlet import REDECLARE_S

log = logging.getLogger("facesynth.link")


class ZenohSubscription(Subscription):
    """One mailbox fed by its session's :class:`Feed` for its key expression."""

    def __init__(self, feed: Feed, maxsize: int) -> None:
        super().__init__(feed.key_expr, maxsize)
        self._feed: Feed | None = feed
        feed.add(self)

    def _release(self) -> None:
        feed, self._feed = self._feed, None
        if feed is not None:
            feed.remove(self)


class Feed:
    """One Zenoh subscriber (samples from other sessions) feeding a session's mailboxes on one
    key expression and event loop."""

    def __init__(self, routes: SessionRoutes, key_expr: str, loop: asyncio.AbstractEventLoop):
        self.routes = routes
        self.key_expr = key_expr
        self.pattern = zenoh.KeyExpr(key_expr)
        self.loop = loop
        self.mailboxes: list[Subscription] = []
        #: When a sample last came from Zenoh (monotonic ns); 0: never.
        self.heard_ns = 0
        self._check_pending = False

        def on_sample(sample: zenoh.Sample) -> None:
            self.heard_ns = time.monotonic_ns()
            # Screened here, on Zenoh's thread, by each mailbox (its size limit before the
            # payload is copied out of Zenoh, then its screen), so refused payloads never
            # reach the event loop.
            payload = sample.payload
            size = len(payload)
            key = str(sample.key_expr)
            data: bytes | None = None
            for mailbox in list(self.mailboxes):
                if mailbox.too_big(size):
                    continue
                if data is None:
                    data = payload.to_bytes()
                mailbox.deliver_threadsafe(key, data)

        self._on_sample = on_sample
        self._subscriber: Any = self._declare()

    def _declare(self) -> Any:
        return self.routes.session.declare_subscriber(
            self.key_expr, self._on_sample, allowed_origin=zenoh.Locality.REMOTE
        )

    def regained(self) -> None:
        """The session has a router again (after none; any thread): unless a sample comes
        within :data:`REDECLARE_S`, declare the Zenoh subscriber anew."""
        if self._check_pending:
            return
        self._check_pending = True
        since = time.monotonic_ns()
        with contextlib.suppress(RuntimeError):  # the loop is closed: nobody listens
            self.loop.call_soon_threadsafe(self.loop.call_later, REDECLARE_S, self._check, since)

    def _check(self, since_ns: int) -> None:
        self._check_pending = False
        if self._subscriber is None or self.heard_ns >= since_ns:
            return
        if not self.declare_anew():
            return
        log.info(
            "subscription %s: nothing heard %.1f s after regaining the router; declared it anew",
            self.key_expr,
            REDECLARE_S,
        )

    def declare_anew(self) -> bool:
        """Undeclare the Zenoh subscriber and declare it again; whether it was (call on the
        feed's loop; not after the last mailbox left)."""
        old, self._subscriber = self._subscriber, None
        if old is None:
            return False
        with contextlib.suppress(Exception):  # the session is already closed
            old.undeclare()
        try:
            self._subscriber = self._declare()
        except Exception as exc:  # the session is closing
            log.debug("subscription %s not declared anew: %s", self.key_expr, exc)
            return False
        return True

    def add(self, mailbox: Subscription) -> None:
        self.mailboxes.append(mailbox)

    def remove(self, mailbox: Subscription) -> None:
        with contextlib.suppress(ValueError):
            self.mailboxes.remove(mailbox)
        if not self.mailboxes:
            self.routes.drop(self)
            subscriber, self._subscriber = self._subscriber, None
            if subscriber is not None:
                with contextlib.suppress(Exception):  # the session is already closed
                    subscriber.undeclare()

    def deliver(self, sample: Sample) -> None:
        """Into every mailbox; call on the feed's event loop thread only."""
        for mailbox in list(self.mailboxes):
            mailbox.deliver(sample)

    def deliver_local(self, sample: Sample) -> None:
        """A publication of this session: at once on the feed's loop, else handed over to it."""
        try:
            running = asyncio.get_running_loop()
        except RuntimeError:
            running = None
        if running is self.loop:
            self.deliver(sample)
        else:
            with contextlib.suppress(RuntimeError):
                self.loop.call_soon_threadsafe(self.deliver, sample)


class SessionRoutes:
    """The feeds of one Zenoh session (shared by every bus on the session)."""

    _by_session: ClassVar[dict[int, SessionRoutes]] = {}

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self.users = 0
        self.feeds: dict[tuple[str, asyncio.AbstractEventLoop], Feed] = {}
        self._targets: dict[str, list[Feed]] = {}

    @classmethod
    def attach(cls, session: zenoh.Session) -> SessionRoutes:
        """The routes of ``session``, counting one more bus on it."""
        routes = cls._by_session.setdefault(id(session), cls(session))
        routes.users += 1
        return routes

    def detach(self) -> None:
        """One bus less on the session; the routes go with the last one."""
        self.users -= 1
        if self.users <= 0:
            self._by_session.pop(id(self.session), None)

    def regained(self) -> None:
        """The session has a router again: each feed checks it hears (:meth:`Feed.regained`)."""
        for feed in list(self.feeds.values()):
            feed.regained()

    def declare_anew(self) -> None:
        """Every feed's subscriber declared again (:meth:`Feed.declare_anew`; on their loop)."""
        try:
            running = asyncio.get_running_loop()
        except RuntimeError:
            running = None
        for feed in list(self.feeds.values()):
            if running is feed.loop:
                feed.declare_anew()
            else:
                with contextlib.suppress(RuntimeError):  # its loop is closed
                    feed.loop.call_soon_threadsafe(feed.declare_anew)

    def feed(self, key_expr: str) -> Feed:
        """The feed of ``key_expr`` on the running loop (declared on first use)."""
        loop = asyncio.get_running_loop()
        feed = self.feeds.get((key_expr, loop))
        if feed is None:
            feed = self.feeds[(key_expr, loop)] = Feed(self, key_expr, loop)
            self._targets.clear()
        return feed

    def drop(self, feed: Feed) -> None:
        """Forget a feed whose last mailbox closed."""
        if self.feeds.get((feed.key_expr, feed.loop)) is feed:
            del self.feeds[(feed.key_expr, feed.loop)]
            self._targets.clear()

    def targets(self, key: str) -> list[Feed]:
        """The feeds whose key expression matches ``key`` (cached until the feeds change)."""
        found = self._targets.get(key)
        if found is None:
            concrete = zenoh.KeyExpr(key)
            found = [f for f in self.feeds.values() if f.pattern.intersects(concrete)]
            if len(self._targets) > 4096:  # keys are few (stages, stats); bound it anyway
                self._targets.clear()
            self._targets[key] = found
        return found
