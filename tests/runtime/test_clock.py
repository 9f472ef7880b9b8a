"""facesynth.runtime.clock: the real clock, and virtual time that moves only when a test says so."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable
from typing import TypeVar

import pytest

from facesynth.runtime.clock import (
    FAKE_EPOCH_NS,
    OFFSET_READ_NS,
    OFFSET_TRIES,
    FakeClock,
    IdleTimeout,
    SystemClock,
    wall_offset_ns,
)

MS = 1_000_000
T = TypeVar("T")


# --- SystemClock -------------------------------------------------------------------------------


async def test_system_clock_reads_the_time_module() -> None:
    clock = SystemClock()
    before_wall, before_mono = time.time_ns(), time.monotonic_ns()
    wall, mono = clock.time_ns(), clock.monotonic_ns()
    assert before_wall <= wall <= time.time_ns()
    assert before_mono <= mono <= time.monotonic_ns()


async def test_system_clock_sleeps_and_times_out_for_real() -> None:
    clock = SystemClock()
    start = time.monotonic_ns()
    await clock.sleep(0.01)
    assert time.monotonic_ns() - start >= 10 * MS
    await clock.sleep(-1.0)  # a negative wait is no wait
    never = asyncio.get_running_loop().create_future()
    with pytest.raises(TimeoutError):
        await clock.wait_for(never, 0.01)
    assert never.cancelled()
    assert await clock.wait_for(asyncio.sleep(0, result="done"), 1.0) == "done"


# --- FakeClock: time ---------------------------------------------------------------------------


async def test_fake_time_stands_still_until_advanced() -> None:
    clock = FakeClock()
    assert (clock.monotonic_ns(), clock.time_ns()) == (0, FAKE_EPOCH_NS)
    sleeper = asyncio.create_task(clock.sleep(1.0))
    await clock.settle()
    assert not sleeper.done() and clock.next_deadline_ns() == 1000 * MS
    await clock.advance(0.999)
    assert not sleeper.done()
    await clock.advance(0.001)
    assert sleeper.done()
    assert clock.monotonic_ns() == 1000 * MS and clock.time_ns() == FAKE_EPOCH_NS + 1000 * MS
    assert clock.seconds == 1.0 and clock.next_deadline_ns() is None


async def test_fake_clock_starts_where_told() -> None:
    clock = FakeClock(start_ns=5 * MS, epoch_ns=10**18)
    assert (clock.monotonic_ns(), clock.time_ns()) == (5 * MS, 10**18 + 5 * MS)


async def test_sleepers_wake_in_deadline_order_at_their_exact_times() -> None:
    clock = FakeClock()
    woke: list[tuple[str, int]] = []

    async def sleeper(name: str, seconds: float) -> None:
        await clock.sleep(seconds)
        woke.append((name, clock.monotonic_ns()))

    tasks = [
        asyncio.create_task(sleeper(name, seconds))
        for name, seconds in [("c", 0.3), ("a", 0.1), ("b1", 0.2), ("b2", 0.2)]
    ]
    await clock.advance(1.0)
    assert all(task.done() for task in tasks)
    assert woke == [("a", 100 * MS), ("b1", 200 * MS), ("b2", 200 * MS), ("c", 300 * MS)]
    assert clock.monotonic_ns() == 1000 * MS


async def test_a_sleeper_that_sleeps_again_wakes_again_within_one_advance() -> None:
    clock = FakeClock()
    ticks: list[int] = []

    async def ticker() -> None:
        while True:
            await clock.sleep(0.25)
            ticks.append(clock.monotonic_ns())

    task = asyncio.create_task(ticker())
    await clock.advance(1.0)
    assert ticks == [250 * MS, 500 * MS, 750 * MS, 1000 * MS]
    task.cancel()
    await clock.settle()
    assert task.cancelled() and clock.next_deadline_ns() is None


async def test_zero_and_negative_sleeps_only_yield() -> None:
    clock = FakeClock()
    await clock.sleep(0)
    await clock.sleep(-3)
    assert clock.monotonic_ns() == 0


async def test_time_only_moves_forward() -> None:
    with pytest.raises(ValueError, match="forward"):
        await FakeClock().advance(-0.1)
    clock = FakeClock(start_ns=10 * MS)
    await clock.advance_to(5 * MS)
    assert clock.monotonic_ns() == 10 * MS


# --- FakeClock: waiting with a timeout ----------------------------------------------------------


async def test_wait_for_returns_as_soon_as_the_awaitable_is_done() -> None:
    clock = FakeClock()
    event = asyncio.Event()
    waiter = asyncio.create_task(clock.wait_for(event.wait(), 1.0))
    await clock.advance(0.3)
    assert not waiter.done()
    event.set()
    await clock.settle()
    assert waiter.result() is True and clock.monotonic_ns() == 300 * MS
    assert clock.next_deadline_ns() is None  # its alarm is gone


async def test_wait_for_times_out_at_exactly_the_timeout_and_cancels_the_awaitable() -> None:
    clock = FakeClock()
    inner = asyncio.create_task(asyncio.Event().wait())
    waiter = asyncio.create_task(clock.wait_for(inner, 0.5))
    await clock.advance(0.499999999)
    assert not waiter.done()
    await clock.advance(0.000000001)
    with pytest.raises(TimeoutError):
        await waiter
    assert inner.cancelled() and clock.monotonic_ns() == 500 * MS


async def test_wait_for_passes_the_awaitables_error_on() -> None:
    async def broken() -> None:
        await clock.sleep(0.1)
        raise KeyError("inner")

    clock = FakeClock()
    waiter = asyncio.create_task(clock.wait_for(broken(), 1.0))
    await clock.advance(0.2)
    with pytest.raises(KeyError, match="inner"):
        await waiter


async def test_cancelling_a_wait_cancels_what_it_waits_for() -> None:
    clock = FakeClock()
    inner = asyncio.create_task(asyncio.Event().wait())
    waiter = asyncio.create_task(clock.wait_for(inner, 1.0))
    await clock.settle()
    waiter.cancel()
    with pytest.raises(asyncio.CancelledError):
        await waiter
    await clock.settle()
    assert inner.cancelled() and clock.next_deadline_ns() is None


async def test_a_zero_timeout_times_out_at_once_without_moving_time() -> None:
    clock = FakeClock()
    inner = asyncio.create_task(asyncio.Event().wait())
    with pytest.raises(TimeoutError):
        await clock.wait_for(inner, 0)
    assert inner.cancelled() and clock.monotonic_ns() == 0


# --- FakeClock: running until something happens ------------------------------------------------


async def test_run_until_stops_at_the_first_instant_the_condition_holds() -> None:
    clock = FakeClock()
    done: list[int] = []

    async def worker() -> None:
        for _ in range(3):
            await clock.sleep(0.4)
            done.append(clock.monotonic_ns())

    task = asyncio.create_task(worker())
    await clock.run_until(lambda: len(done) == 2, timeout=10.0)
    assert not task.done()
    assert clock.monotonic_ns() == 800 * MS and done == [400 * MS, 800 * MS]


async def test_run_until_gives_up_at_its_time_limit() -> None:
    clock = FakeClock()

    async def ticker() -> None:
        while True:
            await clock.sleep(1.0)

    task = asyncio.create_task(ticker())
    with pytest.raises(IdleTimeout, match=r"within 2\.5 s"):
        await clock.run_until(lambda: False, timeout=2.5)
    assert clock.monotonic_ns() == 2500 * MS
    task.cancel()


async def test_run_until_says_when_nothing_is_left_to_wake() -> None:
    with pytest.raises(IdleTimeout, match="nothing pending"):
        await FakeClock().run_until(lambda: False, timeout=1.0)


async def test_settle_refuses_a_loop_that_never_rests() -> None:
    clock = FakeClock()

    async def spinner() -> None:
        while True:
            await asyncio.sleep(0)

    task = asyncio.create_task(spinner())
    with pytest.raises(RuntimeError, match="still busy"):
        await clock.settle()
    task.cancel()


class _ScriptedClock:
    """A clock whose readings come from scripts (monotonic and wall, ns)."""

    def __init__(self, monotonic: list[int], wall: list[int]) -> None:
        self._monotonic, self._wall = iter(monotonic), iter(wall)

    def time_ns(self) -> int:
        return next(self._wall)

    def monotonic_ns(self) -> int:
        return next(self._monotonic)

    async def sleep(self, seconds: float) -> None:  # pragma: no cover - not read
        raise AssertionError

    async def wait_for(self, awaitable: Awaitable[T], timeout: float) -> T:  # pragma: no cover
        raise AssertionError


def test_the_wall_offset_is_read_again_when_a_pause_fell_between_the_readings() -> None:
    offset = 1_000 * MS  # wall = monotonic + 1 s
    # First try: preempted 2 ms right after reading the wall clock (at monotonic 10 ms).
    # Second try: tight. Read once (wall - monotonic after the pause), it is 2 ms short.
    clock = _ScriptedClock(
        monotonic=[10 * MS, 12 * MS, 13 * MS, 13 * MS + 4_000],
        wall=[10 * MS + offset, 13 * MS + 2_000 + offset],
    )
    assert wall_offset_ns(clock) == offset


def test_the_wall_offset_keeps_the_tightest_reading_when_none_is_tight() -> None:
    offset = 5 * MS
    widths = [3 * MS, 1 * MS, 2 * MS]  # each bracket's pause, after the wall reading
    monotonic, wall, now = [], [], 0
    for width in widths:
        monotonic += [now, now + width]
        wall.append(now + offset)
        now += width + MS
    # The midpoint pairing is off by half the bracket: 0.5 ms for the tightest (1 ms) one.
    assert wall_offset_ns(_ScriptedClock(monotonic, wall)) == offset - MS // 2
    assert len(widths) == OFFSET_TRIES and OFFSET_READ_NS < MS


def test_the_system_clock_offset_matches_the_clocks_to_within_a_millisecond() -> None:
    offset = wall_offset_ns(SystemClock())
    assert abs(time.time_ns() - time.monotonic_ns() - offset) < MS
