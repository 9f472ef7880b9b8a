"""A page's outbox: replies in order and bounded, other channels latest-only."""

from __future__ import annotations

from facesynth.app.console.outbox import MAX_REPLIES, Outbox


async def test_replies_keep_their_order_and_the_rest_only_its_newest() -> None:
    box = Outbox()
    box.offer("state", "s1")
    box.say("r1")
    box.offer("state", "s2")
    box.say("r2")
    assert await box.take() == ["r1", "r2", "s2"]


async def test_a_final_reply_supersedes_its_channels_progress() -> None:
    box = Outbox()
    box.offer("calibration", "running")
    box.say("done", replaces="calibration")
    assert await box.take() == ["done"]


async def test_frames_only_for_a_page_that_shows_them_and_replies_are_bounded() -> None:
    box = Outbox()
    box.frames = False
    box.offer("frame", b"jpeg")
    box.offer("points", "p")
    for i in range(MAX_REPLIES + 5):
        box.say(str(i))
    taken = await box.take()
    assert taken == [str(i) for i in range(5, MAX_REPLIES + 5)]
