"""A session's feeds after a regained router: one that hears nothing is declared anew (#28).

A real router and two client sessions on loopback; the regain is what the transport watch
calls when a router is back (``ZenohBus._regained``), so the test takes no router down.
"""

from __future__ import annotations

import asyncio
import logging

import pytest

from facesynth.runtime.bus import zenoh_routes
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions

TIMEOUT = 5.0
#: The regain's delay, shortened so the test takes about a second (read when used).
SHORT_REDECLARE_S = 0.5


async def test_a_feed_that_hears_nothing_after_a_regain_is_declared_anew_once(
    zenoh_router: str,
    key_prefix: str,
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    caplog.set_level(logging.INFO, logger="facesynth.link")
    monkeypatch.setattr(zenoh_routes, "REDECLARE_S", SHORT_REDECLARE_S)
    heard, silent = f"{key_prefix}/heard", f"{key_prefix}/silent"
    sender = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    receiver = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    try:
        streams = receiver.subscribe_latest(heard)
        quiet = receiver.subscribe_queued(silent, 8)
        feeds = {feed.key_expr: feed for feed in receiver._routes.feeds.values()}
        before = {key: feed._subscriber for key, feed in feeds.items()}
        receiver._regained()
        receiver._regained()  # a second regain meanwhile: still one check per feed
        for _ in range(round((SHORT_REDECLARE_S + 0.5) / 0.05)):
            sender.publish(heard, b"frame")
            await asyncio.sleep(0.05)
        assert streams.received > 0
        assert feeds[heard]._subscriber is before[heard], "a feed that hears is left alone"
        assert feeds[silent]._subscriber is not before[silent]
        lines = [r.message for r in caplog.records if "declared it anew" in r.message]
        assert lines == [
            f"subscription {silent}: nothing heard 0.5 s after regaining the router; "
            "declared it anew"
        ]
        await asyncio.sleep(0.3)  # the new declaration reaches the sender's router
        sender.publish(silent, b"now")
        assert (await asyncio.wait_for(quiet.receive(), TIMEOUT)).payload == b"now"
    finally:
        await sender.close()
        await receiver.close()
