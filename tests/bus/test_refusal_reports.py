"""A mailbox's refusals reach its event loop as a few reports a second, never one a message,
and a service logs such a batch as one line.

Under a flood of refused messages (tests/faults/test_flood.py: 10,000 a second on the points
key) one event-loop wake-up per refusal was a third of the receiving stage's CPU, and on a
loaded machine the stream's own frames went stale behind them (issue #28).
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time

import pytest

from facesynth.runtime.bus.base import REFUSAL_REPORT_S, Subscription
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.service import ServiceContext

KEY = "t/refusals"
LIMIT = 10


def _mailbox(reports: list[tuple[int, str]]) -> Subscription:
    subscription = MemoryNetwork().bus().subscribe_queued(KEY, 8)
    subscription.guard(LIMIT, on_refused=lambda count, why: reports.append((count, why)))
    return subscription


async def _wait_reported(reports: list[tuple[int, str]], count: int) -> None:
    for _ in range(500):
        if sum(n for n, _ in reports) >= count:
            return
        await asyncio.sleep(0.01)
    raise AssertionError(f"only {sum(n for n, _ in reports)} of {count} refusals reported")


async def test_a_lone_refusal_is_reported_at_once() -> None:
    reports: list[tuple[int, str]] = []
    subscription = _mailbox(reports)
    subscription.deliver_threadsafe(KEY, b"x" * (LIMIT + 1))
    for _ in range(3):  # the loop's next turns, no timer
        await asyncio.sleep(0)
    assert reports == [(1, f"{LIMIT + 1} bytes, over the limit of {LIMIT}")]


async def test_refusals_one_a_loop_turn_are_reported_in_a_few_batches() -> None:
    reports: list[tuple[int, str]] = []
    subscription = _mailbox(reports)
    started = time.monotonic()
    for i in range(60):  # the loop is idle between them: the old mailbox reported each
        subscription.deliver_threadsafe(KEY, b"x" * (LIMIT + 1 + i))
        await asyncio.sleep(0.001)
    elapsed = time.monotonic() - started
    await _wait_reported(reports, 60)
    assert sum(n for n, _ in reports) == 60 == subscription.refused
    assert len(reports) <= 2 + elapsed / REFUSAL_REPORT_S, (len(reports), elapsed)
    assert reports[-1][1] == f"{LIMIT + 60} bytes, over the limit of {LIMIT}"
    assert subscription.pending() == 0


async def test_a_flood_from_a_transport_thread_is_counted_to_the_last_refusal() -> None:
    reports: list[tuple[int, str]] = []
    subscription = _mailbox(reports)

    def flood() -> None:
        for _ in range(20_000):
            subscription.deliver_threadsafe(KEY, b"x" * (LIMIT + 1))

    thread = threading.Thread(target=flood)
    thread.start()
    while thread.is_alive():
        await asyncio.sleep(0.001)
    await _wait_reported(reports, 20_000)
    assert sum(n for n, _ in reports) == 20_000 == subscription.refused


def test_a_service_logs_a_batch_of_refusals_when_its_count_passes_a_hundred(
    caplog: pytest.LogCaptureFixture,
) -> None:
    ctx = ServiceContext(MemoryNetwork().bus(), "r", "features", instance="i")
    caplog.set_level(logging.WARNING)
    for _ in range(10):  # the first ten, each
        ctx.reject("one")
    logged = len(caplog.records)
    ctx.reject("a flood's batch", 950)  # 10 -> 960: past 100 (one batch, one line)
    ctx.reject("one")  # 961
    ctx.reject("another batch", 39)  # 1000
    lines = [r.getMessage() for r in caplog.records[logged:]]
    assert lines == [
        "dropped a message (960 so far): a flood's batch",
        "dropped a message (1000 so far): another batch",
    ]
    assert ctx.stats.rejected == 1000
