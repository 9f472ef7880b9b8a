"""A router's session: shared memory off, messages bounded by the largest key's limit, and a
legitimate large message still delivered while one over every key's limit is not."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import zenoh

from facesynth.runtime import limits
from facesynth.runtime.bus.router_options import SHM_ENABLED_PATH, router_options
from facesynth.runtime.bus.zenoh_bus import (
    MESSAGE_LIMIT_PATH,
    ZenohOptions,
    open_session,
    router_locators,
)

ROOT = Path(__file__).resolve().parents[2]


def _setting(options: ZenohOptions, path: str) -> object:
    return json.loads(options.build().get_json(path))


def test_the_router_limit_is_the_largest_key_limit_and_passes_a_raw_frame() -> None:
    largest = max(*limits.STAGE_LIMITS.values(), limits.STATS_LIMIT)
    assert limits.router_limit() == largest + limits.MESSAGE_SLACK
    raw_frame = limits.MAX_FRAME_PIXELS * 3
    assert raw_frame < limits.stage_limit("input") < limits.router_limit()
    assert all(
        limits.session_limit(stage) <= limits.router_limit() for stage in limits.STAGE_LIMITS
    )


def test_a_router_session_refuses_shared_memory_and_bounds_messages() -> None:
    options = router_options(ZenohOptions(mode="router"))
    assert _setting(options, SHM_ENABLED_PATH) is False
    assert _setting(options, MESSAGE_LIMIT_PATH) == limits.router_limit()
    assert _setting(ZenohOptions(mode="router"), SHM_ENABLED_PATH) is True  # Zenoh's default


def test_the_callers_own_settings_win() -> None:
    mine = ZenohOptions(mode="router", overrides={SHM_ENABLED_PATH: True, MESSAGE_LIMIT_PATH: 1234})
    options = router_options(mine)
    assert _setting(options, SHM_ENABLED_PATH) is True
    assert _setting(options, MESSAGE_LIMIT_PATH) == 1234
    assert mine.overrides == {SHM_ENABLED_PATH: True, MESSAGE_LIMIT_PATH: 1234}  # not changed


def test_the_zenohd_router_config_says_the_same() -> None:
    options = ZenohOptions(mode=None, config_file=str(ROOT / "deploy" / "zenoh-router.json5"))
    assert _setting(options, SHM_ENABLED_PATH) is False
    assert _setting(options, MESSAGE_LIMIT_PATH) == limits.router_limit()


def test_a_router_passes_a_large_frame_and_drops_what_no_key_accepts() -> None:
    router = open_session(router_options(ZenohOptions(mode="router", listen=["tcp/127.0.0.1:0"])))
    sessions: list[zenoh.Session] = []
    try:
        endpoint = router_locators(router)[0]
        client = ZenohOptions(mode="client", connect=[endpoint])
        # the receiver takes anything: only the router can refuse the oversized message
        receiver = open_session(client.with_message_limit(4 * limits.router_limit()))
        sender = open_session(client)
        sessions += [receiver, sender]
        sizes: list[int] = []
        arrived = threading.Event()

        def take(sample: zenoh.Sample) -> None:
            sizes.append(len(sample.payload.to_bytes()))
            if len(sizes) == 2:
                arrived.set()

        subscriber = receiver.declare_subscriber("router-options/input", take)
        publisher = sender.declare_publisher(
            "router-options/input", congestion_control=zenoh.CongestionControl.BLOCK
        )
        time.sleep(0.5)  # the subscription reaches the router
        raw_720p = 1280 * 720 * 3
        publisher.put(bytes(raw_720p))
        publisher.put(bytes(limits.router_limit() + 1024))
        publisher.put(bytes(100))
        assert arrived.wait(10.0), sizes
        time.sleep(0.5)  # anything else on its way
        assert sizes == [raw_720p, 100]
        subscriber.undeclare()
        publisher.undeclare()
    finally:
        for session in sessions:
            session.close()
        router.close()
