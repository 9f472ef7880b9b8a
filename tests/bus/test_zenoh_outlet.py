"""The Zenoh bus's publisher gate never stays shut on a subscriber that is there (issue #28).

A real router and two client sessions on loopback. The gate (``Outlet``) hands a message to
Zenoh only while a subscriber of another session matches, as Zenoh's matching listener says;
these tests shut it the way a listener that falls silent would leave it, and check that it
opens again by itself (the matching status read again), that a regained router opens it for a
grace period and has a still shut publisher declared anew once, and that it says so.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable

import pytest

from facesynth.runtime.bus import zenoh_outlet
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.bus.zenoh_outlet import MATCH_GRACE_S, RECHECK_S

#: The regain's delays, shortened so the test takes about a second (each is read when used).
SHORT_RECHECK_S, SHORT_REDECLARE_S = 0.3, 0.4

TIMEOUT = 5.0


async def _until(condition: Callable[[], bool], timeout: float = TIMEOUT) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        await asyncio.sleep(0.02)


def _client(router: str) -> ZenohBus:
    return ZenohBus.open(ZenohOptions(mode="client", connect=[router]))


async def test_a_gate_the_listener_left_shut_opens_at_the_next_reading(
    zenoh_router: str, key_prefix: str, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="facesynth.link")
    key = f"{key_prefix}/frames"
    sender, receiver = _client(zenoh_router), _client(zenoh_router)
    try:
        remote = receiver.subscribe_queued(key, 256)
        sender.publish(key, b"first")
        outlet = sender._outlets[key]
        await _until(lambda: outlet.matching)
        await asyncio.sleep(MATCH_GRACE_S)  # past the new publisher's grace
        outlet.matching = False  # the listener's last word was "none", and it fell silent
        shut = time.monotonic()
        seq = 0
        while not outlet.matching:
            assert time.monotonic() - shut < RECHECK_S + 1.0, "the gate stayed shut"
            seq += 1
            sender.publish(key, f"{seq}".encode())
            await asyncio.sleep(0.05)
        sender.publish(key, b"after")
        payloads: list[bytes] = []
        while not payloads or payloads[-1] != b"after":
            payloads.append((await asyncio.wait_for(remote.receive(), TIMEOUT)).payload)
        assert f"{key}: a subscriber matches (read again: the matching listener had not " in (
            caplog.text
        )
    finally:
        await sender.close()
        await receiver.close()


async def test_a_regained_router_opens_the_gate_for_a_grace_then_declares_it_anew_once(
    zenoh_router: str,
    key_prefix: str,
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    caplog.set_level(logging.DEBUG, logger="facesynth.link")  # a key never heard: DEBUG
    monkeypatch.setattr(zenoh_outlet, "RECHECK_S", SHORT_RECHECK_S)
    monkeypatch.setattr(zenoh_outlet, "REDECLARE_S", SHORT_REDECLARE_S)
    key = f"{key_prefix}/points"
    sender, receiver = _client(zenoh_router), _client(zenoh_router)
    try:
        sender.publish(key, b"nobody listens")
        outlet = sender._outlets[key]
        await asyncio.sleep(MATCH_GRACE_S + 0.05)
        assert not outlet.wanted()
        sender._regained()  # what the transport watch calls when a router is back
        assert outlet.wanted(), "every message goes to Zenoh for a grace after a regain"
        first = outlet.publisher
        started = time.monotonic()
        while outlet.publisher is first:
            assert time.monotonic() - started < MATCH_GRACE_S + 2.0, "not declared anew"
            sender.publish(key, b"still nobody")
            await asyncio.sleep(0.05)
        assert "no subscriber matches 0.4 s after regaining the router" in caplog.text
        again = outlet.publisher
        for _ in range(round(3 * SHORT_RECHECK_S / 0.05)):  # once per regain, not every reading
            sender.publish(key, b"still nobody")
            await asyncio.sleep(0.05)
        assert outlet.publisher is again
        remote = receiver.subscribe_queued(key, 8)  # the new publisher's listener follows it
        await _until(lambda: outlet.matching)
        sender.publish(key, b"heard")
        assert (await asyncio.wait_for(remote.receive(), TIMEOUT)).payload == b"heard"
    finally:
        await sender.close()
        await receiver.close()
