"""Time as a seam: service shells read and wait on a :class:`Clock`, never on ``time`` itself.

:class:`SystemClock` is the real one. :class:`FakeClock` keeps virtual time that only moves when a
test advances it, so a test of a watchdog or a ramp runs in milliseconds and can assert exact
times. Pure cores take time as data and need neither.

Two readings, as in :mod:`time`: *wall* time (``time_ns``) stamps messages and is comparable
between processes; *monotonic* time (``monotonic_ns``) measures intervals and deadlines and never
jumps.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import time
from collections.abc import Awaitable, Callable
from typing import Protocol, TypeVar

T = TypeVar("T")

#: The fake clock's wall time at virtual time zero (2023-11-14T22:13:20Z), so stamps look real.
FAKE_EPOCH_NS = 1_700_000_000_000_000_000
#: How many loop turns :meth:`FakeClock.settle` allows before it calls the loop busy.
SETTLE_TURNS = 10_000


class Clock(Protocol):
    """What a service shell needs of time."""

    def time_ns(self) -> int:
        """Wall-clock time in nanoseconds since the epoch (for message timestamps)."""

    def monotonic_ns(self) -> int:
        """Monotonic time in nanoseconds (for intervals and deadlines)."""

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` (at once, but still yielding to the loop, when <= 0)."""

    async def wait_for(self, awaitable: Awaitable[T], timeout: float) -> T:
        """Await ``awaitable``; after ``timeout`` seconds cancel it and raise ``TimeoutError``."""


class SystemClock:
    """The real clock: :mod:`time` and the event loop's own timers."""

    def time_ns(self) -> int:
        return time.time_ns()

    def monotonic_ns(self) -> int:
        return time.monotonic_ns()

    async def sleep(self, seconds: float) -> None:
        await asyncio.sleep(max(0.0, seconds))

    async def wait_for(self, awaitable: Awaitable[T], timeout: float) -> T:
        # asyncio.timeout, not asyncio.wait_for: on Python 3.11 wait_for can swallow a
        # cancellation that races with the awaitable's result, and a service never stops.
        async with asyncio.timeout(max(0.0, timeout)):
            return await awaitable


class IdleTimeout(AssertionError):
    """:meth:`FakeClock.run_until` reached its time limit before its condition held."""


class FakeClock:
    """Virtual time for tests: still until :meth:`advance` (or :meth:`run_until`) moves it.

    Sleepers wake in deadline order (ties in the order they started sleeping), and before each
    wake-up every task that can run at the current instant has run (:meth:`settle`), so a test
    sees exactly what a real run would see at that instant, without waiting for it.
    Use one fake clock per event loop, from inside that loop.
    """

    def __init__(self, start_ns: int = 0, epoch_ns: int = FAKE_EPOCH_NS) -> None:
        self._now = start_ns
        self._epoch = epoch_ns
        self._sleepers: list[tuple[int, int, asyncio.Future[None]]] = []
        self._order = itertools.count()

    # --- the Clock protocol ------------------------------------------------------------------

    def time_ns(self) -> int:
        return self._epoch + self._now

    def monotonic_ns(self) -> int:
        return self._now

    async def sleep(self, seconds: float) -> None:
        if seconds <= 0:
            await asyncio.sleep(0)
            return
        await self._alarm(self._now + _to_ns(seconds))

    async def wait_for(self, awaitable: Awaitable[T], timeout: float) -> T:
        task = asyncio.ensure_future(awaitable)
        alarm = asyncio.ensure_future(self._alarm(self._now + _to_ns(max(0.0, timeout))))
        try:
            await asyncio.wait({task, alarm}, return_when=asyncio.FIRST_COMPLETED)
        except asyncio.CancelledError:
            task.cancel()
            alarm.cancel()
            raise
        alarm.cancel()
        if task.done():
            return task.result()
        task.cancel()
        try:
            return await task  # it finished while being cancelled: keep what it got
        except asyncio.CancelledError:
            current = asyncio.current_task()
            if current is not None and current.cancelling():
                raise  # the caller itself is being cancelled
            raise TimeoutError from None

    # --- what tests call ---------------------------------------------------------------------

    @property
    def seconds(self) -> float:
        """Virtual monotonic time in seconds (for messages; assert on ``monotonic_ns``)."""
        return self._now / 1e9

    def next_deadline_ns(self) -> int | None:
        """When the earliest sleeper wakes, or ``None`` if nobody sleeps."""
        self._forget_cancelled()
        return self._sleepers[0][0] if self._sleepers else None

    async def settle(self) -> None:
        """Let every task that can run at the current instant run, without moving time.

        Reads asyncio's run queue to know when nothing is left to run (and refuses a loop that
        never rests); on a loop without one (uvloop) it yields ``SETTLE_TURNS`` times instead.
        """
        loop = asyncio.get_running_loop()
        ready = getattr(loop, "_ready", None)  # asyncio's run queue; absent on other loops
        for _ in range(SETTLE_TURNS):
            await asyncio.sleep(0)
            if ready is not None and not ready:
                return
        if ready is not None:
            raise RuntimeError(f"the loop is still busy after {SETTLE_TURNS} turns")

    async def advance(self, seconds: float) -> None:
        """Move time forward by ``seconds``, waking every sleeper due on the way, in order."""
        if seconds < 0:
            raise ValueError("time only moves forward")
        await self.advance_to(self._now + _to_ns(seconds))

    async def advance_to(self, target_ns: int) -> None:
        """Move time forward to ``target_ns`` (monotonic), waking sleepers due on the way."""
        await self.settle()
        while (deadline := self.next_deadline_ns()) is not None and deadline <= target_ns:
            self._now = max(self._now, deadline)
            self._wake_due()
            await self.settle()
        self._now = max(self._now, target_ns)
        await self.settle()

    async def run_until(self, condition: Callable[[], bool], timeout: float) -> None:
        """Jump from deadline to deadline until ``condition()`` holds.

        Time stops at the first instant where it holds. Raises :class:`IdleTimeout` if it
        does not hold within ``timeout`` virtual seconds (or nobody is left to wake).
        """
        limit = self._now + _to_ns(timeout)
        await self.settle()
        while not condition():
            deadline = self.next_deadline_ns()
            if deadline is None or deadline > limit:
                if deadline is None:
                    raise IdleTimeout(f"condition not met at {self.seconds:.3f} s: nothing pending")
                self._now = limit
                await self.settle()
                if condition():
                    return
                raise IdleTimeout(f"condition not met within {timeout} s (at {self.seconds} s)")
            self._now = deadline
            self._wake_due()
            await self.settle()

    # --- internals ---------------------------------------------------------------------------

    async def _alarm(self, deadline_ns: int) -> None:
        if deadline_ns <= self._now:  # already due: no need to wait for the test to move time
            await asyncio.sleep(0)
            return
        future = asyncio.get_running_loop().create_future()
        heapq.heappush(self._sleepers, (deadline_ns, next(self._order), future))
        await future

    def _forget_cancelled(self) -> None:
        while self._sleepers and self._sleepers[0][2].done():
            heapq.heappop(self._sleepers)

    def _wake_due(self) -> None:
        while self._sleepers and self._sleepers[0][0] <= self._now:
            _, _, future = heapq.heappop(self._sleepers)
            if not future.done():
                future.set_result(None)


def _to_ns(seconds: float) -> int:
    return round(seconds * 1e9)


#: A reading of the wall clock's offset is taken as exact once the monotonic readings around it
#: are this close (ns); otherwise it is read again (see :func:`wall_offset_ns`).
OFFSET_READ_NS = 50_000
#: How many times :func:`wall_offset_ns` reads at most (it keeps the tightest reading).
OFFSET_TRIES = 3


def wall_offset_ns(clock: Clock) -> int:
    """The wall clock's offset from the monotonic one (wall - monotonic, ns), read so that a
    pause between the two readings (the thread preempted on a loaded machine) cannot skew it.

    The wall reading is bracketed by two monotonic ones and paired with their midpoint; a
    bracket wider than :data:`OFFSET_READ_NS` is read again, up to :data:`OFFSET_TRIES` times,
    and the tightest kept. (``time_ns() - monotonic_ns()`` read once was 2 ms off in a soak:
    a controller step stamped 2 ms early looked 5 % over its speed limit.)
    """
    best: tuple[int, int] | None = None  # (bracket width, offset)
    for _ in range(OFFSET_TRIES):
        before = clock.monotonic_ns()
        wall = clock.time_ns()
        after = clock.monotonic_ns()
        reading = (after - before, wall - (before + after) // 2)
        if best is None or reading[0] < best[0]:
            best = reading
        if reading[0] <= OFFSET_READ_NS:
            break
    assert best is not None
    return best[1]
