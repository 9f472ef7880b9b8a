"""A Zenoh bus whose router has lost its declarations declares them anew (issue #28).

The pure part (:func:`watch`: when to act) with plain functions for the question; then a real
router and two client sessions on loopback, the bus's token withdrawn behind its back, as a
router that has lost it looks to the question.
"""

from __future__ import annotations

import asyncio
import logging
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable

import pytest

from facesynth.runtime.bus import zenoh_selfcheck
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.bus.zenoh_selfcheck import SILENT_LIMIT, router_holds, watch
from tests.facesynth_processes import free_port

TIMEOUT = 5.0


async def _run_watch(
    answers: list[bool | None], connected: Callable[[], bool] = lambda: True
) -> tuple[int, int]:
    """How many questions ``watch`` asked and how often it declared anew, given ``answers``."""
    asked, anew = [0], [0]

    def ask() -> bool | None:
        asked[0] += 1
        return answers.pop(0) if answers else True

    def declare_anew() -> None:
        anew[0] += 1

    task = asyncio.create_task(watch(ask, connected, declare_anew))
    await asyncio.sleep(0.5)
    task.cancel()
    return asked[0], anew[0]


@pytest.fixture
def quick(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(zenoh_selfcheck, "CHECK_S", 0.01)


@pytest.mark.usefixtures("quick")
async def test_two_noes_in_a_row_declare_anew_once_and_a_timeout_is_no_verdict() -> None:
    assert (await _run_watch([False, None, True, False, True]))[1] == 0
    assert (await _run_watch([False, None, False]))[1] == 1  # no verdict breaks no run


@pytest.mark.usefixtures("quick")
async def test_questions_without_a_verdict_count_as_one_no_only_so_many_in_a_row() -> None:
    silent = [None] * SILENT_LIMIT
    assert (await _run_watch([*silent[:-1], True, *silent[:-1], False]))[1] == 0
    assert (await _run_watch([*silent, False]))[1] == 1  # a router that stopped answering
    assert (await _run_watch(silent + silent))[1] == 1


@pytest.mark.usefixtures("quick")
async def test_a_router_that_keeps_saying_no_has_everything_declared_anew_at_most_so_often(
    caplog: pytest.LogCaptureFixture,
) -> None:
    asked, anew = await _run_watch([False] * 1000)
    assert anew == 1 and asked > 10
    assert caplog.text.count("declaring every subscription, publisher and token anew") == 1


@pytest.mark.usefixtures("quick")
async def test_nothing_is_asked_without_a_router() -> None:
    assert await _run_watch([False] * 100, connected=lambda: False) == (0, 0)


async def test_a_bus_whose_router_lost_its_token_declares_everything_anew(
    zenoh_router: str,
    key_prefix: str,
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    caplog.set_level(logging.INFO, logger="facesynth.link")
    monkeypatch.setattr(zenoh_selfcheck, "CHECK_S", 0.2)
    stage = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    other = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    health, inbox, outbox = f"{key_prefix}/health/f", f"{key_prefix}/points", f"{key_prefix}/feat"
    try:
        token = stage.declare_token(health)
        points = stage.subscribe_queued(inbox, 8)
        features = other.subscribe_queued(outbox, 8)
        await asyncio.sleep(0.3)
        assert await asyncio.to_thread(router_holds, stage.session, health)
        # Gone from the router (and the session) behind the bus's back: the token, then the
        # subscription (while the router lists one of the session's, it holds them).
        token._token.undeclare()  # type: ignore[attr-defined]
        assert await asyncio.to_thread(router_holds, stage.session, health)
        next(iter(stage._routes.feeds.values()))._subscriber.undeclare()
        await asyncio.sleep(0.2)
        assert not await asyncio.to_thread(router_holds, stage.session, health)
        started = time.monotonic()
        while health not in await other.alive(f"{key_prefix}/health/*"):
            assert time.monotonic() - started < TIMEOUT, "the token never came back"
            await asyncio.sleep(0.1)
        assert "the router holds none of this session's declarations" in caplog.text
        other.publish(inbox, b"points")  # the subscription declared anew still hears
        assert (await asyncio.wait_for(points.receive(), TIMEOUT)).payload == b"points"
        stage.publish(outbox, b"features")  # and the publisher still reaches the other
        assert (await asyncio.wait_for(features.receive(), TIMEOUT)).payload == b"features"
    finally:
        await stage.close()
        await other.close()


async def test_a_session_without_subscriptions_is_vouched_for_by_its_token_alone(
    zenoh_router: str, key_prefix: str
) -> None:
    """The sensor publishes only: the router's entry for its token (listing this session, not
    another holding the same key) is what says the router holds it."""
    stage = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    other = ZenohBus.open(ZenohOptions(mode="client", connect=[zenoh_router]))
    health = f"{key_prefix}/health/s"
    try:
        token = stage.declare_token(health)
        other.declare_token(health)
        stage.publish(f"{key_prefix}/input", b"frame")
        await asyncio.sleep(0.3)
        assert await asyncio.to_thread(router_holds, stage.session, health) is True
        token._token.undeclare()  # type: ignore[attr-defined]
        await asyncio.sleep(0.2)
        assert await asyncio.to_thread(router_holds, stage.session, health) is False
        assert await asyncio.to_thread(router_holds, other.session, health) is True
    finally:
        await stage.close()
        await other.close()


async def test_a_router_answering_late_gives_no_verdict_not_a_lost_token(key_prefix: str) -> None:
    """The router's answer held back past the question's timeout (its process paused, as a
    busy stage on a loaded machine saw it): no verdict, where it used to read as lost."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = subprocess.Popen(
        [sys.executable, "-m", "facesynth", "router", "--listen", endpoint],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    try:
        assert router.stdout is not None and "listening on" in router.stdout.readline()
        stage = ZenohBus.open(ZenohOptions(mode="client", connect=[endpoint]))
        try:
            health = f"{key_prefix}/health/p"
            stage.declare_token(health)
            stage.subscribe_queued(f"{key_prefix}/frames", 8)
            await asyncio.sleep(0.3)
            assert await asyncio.to_thread(router_holds, stage.session, health, 2.0) is True
            os.kill(router.pid, signal.SIGSTOP)
            try:
                late = await asyncio.to_thread(router_holds, stage.session, health, 0.3)
            finally:
                os.kill(router.pid, signal.SIGCONT)
            assert late is None
            assert await asyncio.to_thread(router_holds, stage.session, health, 2.0) is True
        finally:
            await stage.close()
    finally:
        router.terminate()
        router.wait(10)
