"""facesynth.services.control.drivers.replies: answers matched to requests in order."""

from __future__ import annotations

import asyncio

import pytest

from facesynth.services.control.drivers.replies import ReplyQueue


async def test_answers_by_size_and_terminator_in_order() -> None:
    queue = ReplyQueue()
    version = queue.expect(until=b"\r")
    moving = queue.expect(size=1)
    errors = queue.expect(size=2)
    queue.feed(b"SSC32-V2")
    assert not version.done()
    queue.feed(b".50\r+\x10")
    assert version.result() == b"SSC32-V2.50\r" and moving.result() == b"+"
    assert not errors.done() and queue.pending == 1
    queue.feed(b"\x00")
    assert errors.result() == b"\x10\x00" and queue.pending == 0


async def test_stray_bytes_and_abandoned_requests() -> None:
    queue = ReplyQueue(limit=8)
    queue.feed(b"noise")
    assert queue.stray == 5
    late = queue.expect(size=2)
    late.cancel()  # its caller gave up: the next answer goes to the next request
    nextone = queue.expect(size=1)
    queue.feed(b"x")
    assert nextone.result() == b"x"
    line = queue.expect(until=b"\r")
    queue.feed(b"123456789")  # longer than the limit without a terminator
    with pytest.raises(ValueError, match="too long"):
        line.result()
    pending = queue.expect(size=4)
    queue.reset()
    assert pending.cancelled() and queue.pending == 0
    with pytest.raises(ValueError):
        queue.expect()
    await asyncio.sleep(0)


async def test_an_answer_too_long_in_pieces_is_refused_and_the_next_one_read() -> None:
    # Each piece short of the limit, the whole past it (found by the fuzz suite: accepted).
    queue = ReplyQueue(limit=8)
    version = queue.expect(until=b"\r")
    moving = queue.expect(size=1)
    queue.feed(b"SSC32-")
    queue.feed(b"V2.50\r+")
    with pytest.raises(ValueError, match="too long"):
        version.result()
    assert moving.result() == b"+" and queue.stray == 12
