"""services.control.drivers.virtual.fanout: latest-only mailboxes, one per page."""

from __future__ import annotations

import asyncio

from services.control.drivers.virtual.fanout import Fanout, Mailbox


async def test_a_mailbox_keeps_the_newest_message_of_each_channel() -> None:
    box = Mailbox()
    box.offer("face", "f1")
    box.offer("stats", "s1")
    box.offer("face", "f2")
    box.offer("frame", b"jpeg")
    assert box.pending() == 3 and box.dropped == 1
    assert await box.take() == ["f2", b"jpeg", "s1"]
    box.offer("face", "f3")
    assert await box.take() == ["f3"]
    assert (box.offered, box.sent, box.dropped) == (5, 4, 1)


async def test_take_sends_in_channel_order() -> None:
    box = Mailbox()
    for channel in ("stats", "frame", "points", "face", "pong"):
        box.offer(channel, channel)
    assert await box.take() == ["pong", "face", "points", "frame", "stats"]


async def test_take_waits_for_an_offer() -> None:
    box = Mailbox()
    waiter = asyncio.create_task(box.take())
    await asyncio.sleep(0.01)
    assert not waiter.done()
    box.offer("face", "x")
    assert await asyncio.wait_for(waiter, 1) == ["x"]


async def test_a_page_without_frames_gets_no_frames_or_points() -> None:
    box = Mailbox(frames=False)
    box.offer("frame", b"x")
    box.offer("points", "p")
    box.offer("face", "f")
    assert await box.take() == ["f"]


async def test_fanout_offers_to_every_page_and_never_waits() -> None:
    fanout = Fanout()
    stuck, reader = fanout.add(), fanout.add(frames=False)
    for i in range(100):
        fanout.offer("face", str(i))  # nobody takes from `stuck`: it only keeps the newest
    assert await reader.take() == ["99"]
    assert stuck.pending() == 1 and stuck.dropped == 99
    assert fanout.wants_frames()
    fanout.remove(stuck)
    assert not fanout.wants_frames()
    assert fanout.dropped == 99 + 99  # a page that left keeps its count
    fanout.remove(stuck)  # twice is harmless
    assert fanout.offered == 100
