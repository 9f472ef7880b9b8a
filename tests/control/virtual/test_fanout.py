"""facesynth.services.control.drivers.virtual.fanout: latest-only mailboxes, one per page (with the
console's replies in order)."""

from __future__ import annotations

import asyncio

from facesynth.services.control.drivers.virtual.fanout import MAX_REPLIES, Fanout, Mailbox


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


async def test_replies_keep_their_order_and_the_rest_only_its_newest() -> None:
    box = Mailbox(order=())
    box.offer("state", "s1")
    box.say("r1")
    box.offer("state", "s2")
    box.say("r2")
    assert await box.take() == ["r1", "r2", "s2"]


async def test_a_final_reply_supersedes_its_channels_progress() -> None:
    box = Mailbox(order=())
    box.offer("calibration", "running")
    box.say("done", replaces="calibration")
    assert await box.take() == ["done"]


async def test_frames_only_for_a_page_that_shows_them_and_replies_are_bounded() -> None:
    box = Mailbox(order=())
    box.frames = False
    box.offer("frame", b"jpeg")
    box.offer("points", "p")
    for i in range(MAX_REPLIES + 5):
        box.say(str(i))
    taken = await box.take()
    assert taken == [str(i) for i in range(5, MAX_REPLIES + 5)]


async def test_channels_outside_the_order_follow_in_the_order_they_came() -> None:
    box = Mailbox()
    for channel in ("state", "stats", "control", "face"):
        box.offer(channel, channel)
    assert await box.take() == ["face", "stats", "state", "control"]
    unordered = Mailbox(order=())
    for channel in ("state", "stats", "control", "face"):
        unordered.offer(channel, channel)
    assert await unordered.take() == ["state", "stats", "control", "face"]


class _Socket:
    """What a writer sends to, recorded (aiohttp's WebSocket in the servers)."""

    def __init__(self) -> None:
        self.closed = False
        self.sent: list[str | bytes] = []

    async def send_str(self, data: str) -> None:
        self.sent.append(data)

    async def send_bytes(self, data: bytes) -> None:
        self.sent.append(data)


async def test_a_writer_sends_while_sending_and_stops_after() -> None:
    box, ws = Mailbox(), _Socket()
    async with box.sending(ws, "writer"):
        box.say("hello")
        box.offer("frame", b"jpeg")
        await asyncio.sleep(0.01)
        assert ws.sent == ["hello", b"jpeg"]
    assert not [t for t in asyncio.all_tasks() if t.get_name() == "writer"]
    box.offer("face", "late")
    await asyncio.sleep(0.01)
    assert ws.sent == ["hello", b"jpeg"] and box.pending() == 1
