"""The bus seam: how services publish and subscribe, whatever carries the bytes.

Two implementations share this contract (and one contract test suite):
:class:`facesynth.runtime.bus.zenoh_bus.ZenohBus` for real deployments and
:class:`facesynth.runtime.bus.memory.MemoryBus` for unit tests.

Subscriptions are mailboxes owned by the asyncio loop: a transport thread hands samples over
with ``loop.call_soon_threadsafe`` and never blocks. A *latest* subscription keeps only the newest
sample (older ones count as dropped); a *queued* one keeps up to ``maxsize`` and drops the oldest
when full, also counted.

**Messages within a process travel as objects.** :meth:`Bus.publish_message` takes the message
itself (an immutable struct) in a :class:`Parcel`: a mailbox of the same process that *takes*
objects (:meth:`Subscription.guard`'s ``take``, which checks the object as its screen checks
decoded bytes) gets that very object, without msgpack; the bytes are encoded at most once, and
only when a mailbox that reads bytes (a recorder) or a subscriber in another process wants them.
"""

from __future__ import annotations

import abc
import asyncio
import collections
import contextlib
import math
import threading
import time
from collections.abc import AsyncIterator, Callable
from types import TracebackType
from typing import Any, Self

from facesynth.runtime.bus.link import LinkFigures
from facesynth.runtime.bus.sample import Sample

#: Refusals on arrival are reported to a mailbox's ``on_refused`` at most this often (seconds;
#: the first at once): a flood of refused messages wakes the event loop about ten times a
#: second, not once a message (issue #28: at 10,000 a second those wake-ups were a third of
#: the receiving stage's CPU, and on a loaded machine the stream's frames went stale behind them).
REFUSAL_REPORT_S = 0.1


class SubscriptionClosed(Exception):
    """Raised by :meth:`Subscription.receive` once the subscription or its bus is closed."""


class Subscription:
    """A bounded mailbox of samples, filled by the transport, drained by one asyncio task."""

    def __init__(self, key: str, maxsize: int) -> None:
        if maxsize < 1:
            raise ValueError("a subscription needs room for at least one sample")
        self.key = key
        self.maxsize = maxsize
        self.dropped = 0
        self.received = 0
        self._items: collections.deque[Sample] = collections.deque()
        self._waiter: asyncio.Future[None] | None = None
        self._closed = False
        self._loop = asyncio.get_running_loop()
        #: Payloads over this many bytes are refused before they are copied or queued.
        self.max_bytes: int | None = None
        #: Payloads refused on arrival (too big, or refused by the screen).
        self.refused = 0
        self._screen: Callable[[bytes], Any] | None = None
        self._take: Callable[[Any], Any] | None = None
        self._on_refused: Callable[[int, str], None] | None = None
        self._refusals = 0  # refused since the last report to ``on_refused``
        self._reason = ""
        self._report_pending = False
        self._reported_at = -math.inf  # loop time of the last report to ``on_refused``
        self._refusal_lock = threading.Lock()  # the count is kept by two threads
        #: Polled (see :meth:`poll_only`): samples are stored under this lock, nobody is woken.
        self._polled: threading.Lock | None = None

    def poll_only(self) -> None:
        """Never wake the event loop for a sample: the reader drains the mailbox with
        :meth:`receive_nowait` when it needs to (a side stream read between the service's own
        messages), so a sample costs no event-loop wake-up. Samples from a transport thread
        are stored there at once, under a lock. :meth:`receive` is not for such a mailbox."""
        self._polled = threading.Lock()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called (pending samples can no longer be received)."""
        return self._closed

    def guard(
        self,
        max_bytes: int,
        screen: Callable[[bytes], Any] | None = None,
        on_refused: Callable[[int, str], None] | None = None,
        take: Callable[[Any], Any] | None = None,
    ) -> None:
        """Refuse, on arrival, payloads over ``max_bytes`` (before they are copied out of the
        transport) and, with ``screen``, payloads it refuses by raising ``ValueError`` (its
        result becomes the sample's ``message``). A refused payload never enters the mailbox:
        it neither displaces a good one nor wakes the reader, so a flood of bad messages
        cannot crowd out the stream.

        ``on_refused(count, reason)`` is called on the event loop with how many were refused
        since its last call and why the latest was, on the loop's next turn; from a transport's
        thread, whose every report wakes the loop, after a quiet :data:`REFUSAL_REPORT_S` at
        once, else that long after the last call: a flood costs the loop a few wake-ups a second.

        With ``take``, the mailbox takes messages published in this process as they are
        (:meth:`Bus.publish_message`): ``take(message)`` checks the object as ``screen`` checks
        what it decodes (refusing by raising ``ValueError``, counted and reported alike) and
        its result becomes the sample's ``message``; nothing is encoded or decoded. Without
        it, such a message reaches the mailbox as bytes, encoded once for all its readers. No
        byte limit applies to an object (it has no bytes); ``take`` checks its counts.
        """
        self.max_bytes = max_bytes
        self._screen = screen
        self._on_refused = on_refused
        self._take = take

    def limit(self, max_bytes: int) -> None:
        """Refuse payloads over ``max_bytes`` on arrival (see :meth:`guard`)."""
        self.guard(max_bytes, self._screen, self._on_refused, self._take)

    def too_big(self, size: int, *, transport: bool = True) -> bool:
        """Whether a payload of ``size`` bytes is refused (and count it); any thread
        (``transport``: a transport's thread, whose reports are spaced, see :meth:`guard`)."""
        if self.max_bytes is None or size <= self.max_bytes:
            return False
        self._refuse(f"{size} bytes, over the limit of {self.max_bytes}", transport)
        return True

    def _admit(self, payload: bytes, transport: bool) -> tuple[bool, Any]:
        """Whether ``payload`` may enter the mailbox, and its screened message; any thread."""
        if self.too_big(len(payload), transport=transport):
            return False, None
        if self._screen is None:
            return True, None
        try:
            return True, self._screen(payload)
        except ValueError as exc:
            self._refuse(str(exc), transport)
            return False, None

    def _refuse(self, reason: str, transport: bool) -> None:
        """Count a refusal and see it reported: on the loop's next turn, or, from a
        transport's thread, at most every :data:`REFUSAL_REPORT_S` (each report wakes the
        loop; a refusal on the loop's own path, an in-process publish, wakes nobody)."""
        with self._refusal_lock:
            self.refused += 1
            self._refusals += 1
            self._reason = reason
            if self._on_refused is None or self._report_pending:
                return
            self._report_pending = True
        report = self._report_when_due if transport else self._report_refusals
        with contextlib.suppress(RuntimeError):  # the loop is closed: nobody to tell
            self._loop.call_soon_threadsafe(report)

    def _report_when_due(self) -> None:
        """Report now, or :data:`REFUSAL_REPORT_S` after the last report (on the loop)."""
        wait = self._reported_at + REFUSAL_REPORT_S - self._loop.time()
        if wait > 0:
            self._loop.call_later(wait, self._report_refusals)
        else:
            self._report_refusals()

    def _report_refusals(self) -> None:
        with self._refusal_lock:
            count, reason = self._refusals, self._reason
            self._refusals, self._report_pending = 0, False
        self._reported_at = self._loop.time()
        if count and self._on_refused is not None:
            self._on_refused(count, reason)

    def deliver(self, sample: Sample) -> None:
        """Add a sample (screened, unless it comes screened from :meth:`deliver_threadsafe`;
        an in-process message taken as it is, with ``take``); call on the subscription's event
        loop thread only."""
        if self._closed:
            return
        parcel = sample.parcel
        if parcel is not None and self._take is not None:
            try:
                message = self._take(parcel.message)
            except ValueError as exc:
                self._refuse(str(exc), transport=False)
                return
            sample = Sample(sample.key, parcel, sample.t_received_ns, message)
        elif sample.message is None and (self.max_bytes is not None or self._screen is not None):
            admitted, message = self._admit(sample.payload, transport=False)
            if not admitted:
                return
            if message is not None:
                sample = Sample(sample.key, sample.payload, sample.t_received_ns, message)
        if self._polled is not None:
            self._store_polled(sample)
            return
        self._store(sample)
        waiter = self._waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    def _store(self, sample: Sample) -> None:
        self.received += 1
        if len(self._items) >= self.maxsize:
            self._items.popleft()
            self.dropped += 1
        self._items.append(sample)

    def _store_polled(self, sample: Sample) -> None:
        assert self._polled is not None
        with self._polled:
            if not self._closed:
                self._store(sample)

    def deliver_threadsafe(self, key: str, payload: bytes) -> None:
        """Screen a sample on the calling (transport) thread, then hand it over without
        blocking."""
        admitted, message = self._admit(payload, transport=True)
        if not admitted:
            return
        sample = Sample(key, payload, time.time_ns(), message)
        if self._polled is not None:
            self._store_polled(sample)
            return
        # A closed loop means the service is shutting down: the sample is not needed.
        with contextlib.suppress(RuntimeError):
            self._loop.call_soon_threadsafe(self.deliver, sample)

    async def receive(self) -> Sample:
        """Wait for the next sample (the newest one for a latest subscription)."""
        if self._polled is not None:
            raise RuntimeError("a polled subscription is drained with receive_nowait()")
        while not self._items:
            if self._closed:
                raise SubscriptionClosed(self.key)
            self._waiter = self._loop.create_future()
            try:
                await self._waiter
            finally:
                self._waiter = None
        return self._items.popleft()

    def receive_nowait(self) -> Sample | None:
        """The next pending sample, or ``None``."""
        if self._polled is not None:
            with self._polled:
                return self._items.popleft() if self._items else None
        return self._items.popleft() if self._items else None

    def pending(self) -> int:
        """How many samples wait to be received."""
        return len(self._items)

    def close(self) -> None:
        """Stop receiving; a task waiting in :meth:`receive` gets :class:`SubscriptionClosed`."""
        if self._closed:
            return
        with self._polled or contextlib.nullcontext():
            self._closed = True
            self._items.clear()
        self._release()
        waiter = self._waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    def _release(self) -> None:
        """Undeclare transport resources; implementations override."""

    def __aiter__(self) -> AsyncIterator[Sample]:
        return self._iterate()

    async def _iterate(self) -> AsyncIterator[Sample]:
        while True:
            try:
                yield await self.receive()
            except SubscriptionClosed:
                return


class Token(abc.ABC):
    """A liveliness token: visible to :meth:`Bus.alive` until closed or its process dies."""

    @abc.abstractmethod
    def close(self) -> None:
        """Withdraw the token."""


class Bus(abc.ABC):
    """Publish bytes on keys, subscribe to key expressions, announce liveliness.

    A bus is an async context manager: ``async with bus:`` closes it on the way out
    (:meth:`close` still works on its own).

    **Publishing never waits for subscribers.** :meth:`publish` hands the message to the
    transport and returns. A subscriber that is slow, stuck or stopped loses messages; it
    neither holds up the publisher nor the other subscribers:

    - in the publisher's own process (the in-memory bus, or a Zenoh subscription of the same
      service) its mailbox keeps ``maxsize`` samples and drops the oldest, counted in
      ``dropped``. Samples reach the mailbox when the event loop next runs, so a service
      yields between messages (every shell does);
    - over Zenoh every publication uses ``CongestionControl.DROP``: when the queue towards a
      congested subscriber or router is full, Zenoh waits at most ``wait_before_drop`` (1 ms
      by default; a message above one 64 KiB batch travels in fragments and may wait up to
      ``max_wait_before_drop_fragments``, 50 ms) and drops it for that path only. Measured on
      loopback with a SIGSTOPped subscriber process and a healthy one behind one router, 400
      messages of 50 kB at 200/s, no shared memory (``tests/bus/congestion_probe.py``):
      ``publish`` took at most 1-25 ms and the healthy subscriber's longest gap was 13-160 ms
      (on a loaded machine it lost up to 10 % of the messages as well, never the stream).
      With ``BLOCK`` instead, one ``put`` held the publisher's event loop 4.6 s and the
      healthy subscriber got nothing for 5.0 s, until Zenoh closed the stopped one's link
      (``wait_before_close``); ``tests/bus/test_publish_congestion.py`` holds this promise.

    The price is that a message can be lost on a congested path. facesynth's streams are real
    time (the newest message wins), and ``--fast`` replays are paced by the sensor's credit
    window, which sends on after ``ack_timeout`` if a frame or its result was lost.
    """

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        await self.close()

    @abc.abstractmethod
    def publish(self, key: str, payload: bytes) -> None:
        """Send ``payload`` on ``key``; returns without waiting for any subscriber."""

    @abc.abstractmethod
    def publish_message(self, key: str, message: Any, encode: Callable[[Any], bytes]) -> None:
        """Send ``message`` on ``key`` as :meth:`publish` sends bytes: mailboxes of this process
        that take objects get ``message`` itself, the others and other processes get
        ``encode(message)``, called at most once and only when someone wants bytes.

        ``message`` is shared by every reader from here on: nobody may change it (facesynth's
        message structs are frozen).
        """

    @abc.abstractmethod
    def _subscribe(self, key_expr: str, maxsize: int) -> Subscription:
        """Create a subscription mailbox of ``maxsize`` for ``key_expr``."""

    def subscribe_latest(self, key_expr: str) -> Subscription:
        """Subscribe keeping only the newest sample (for real-time inputs)."""
        return self._subscribe(key_expr, 1)

    def subscribe_queued(self, key_expr: str, maxsize: int = 64) -> Subscription:
        """Subscribe keeping up to ``maxsize`` samples in order, dropping the oldest when full."""
        return self._subscribe(key_expr, maxsize)

    @abc.abstractmethod
    def declare_token(self, key: str) -> Token:
        """Announce liveliness on ``key``."""

    @abc.abstractmethod
    async def alive(self, key_expr: str, timeout: float = 1.0) -> list[str]:
        """Keys of the liveliness tokens currently matching ``key_expr``."""

    def link(self, now_ns: int | None = None) -> LinkFigures | None:
        """How the link to the router has fared (at ``now_ns``, monotonic, default now), or
        ``None`` where there is no router to lose (an in-memory bus, a router's own session)."""
        return None

    @abc.abstractmethod
    async def close(self) -> None:
        """Close every subscription and token and release the transport."""
