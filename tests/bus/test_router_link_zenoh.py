"""A Zenoh bus logs losing and regaining its router, and reports it (real router, loopback)."""

from __future__ import annotations

import logging
import socket
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions, open_session

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _router(port: int) -> object:
    return open_session(
        ZenohOptions(
            mode="router",
            listen=[f"tcp/127.0.0.1:{port}"],
            config_file=str(DEPLOY / "zenoh-router.json5"),
        )
    )


def _until(condition: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.02)


async def test_service_logs_losing_and_regaining_its_router(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger="facesynth.link")
    port = _free_port()
    router = _router(port)
    bus = ZenohBus.open(
        ZenohOptions(
            connect=[f"tcp/127.0.0.1:{port}"],
            config_file=str(DEPLOY / "zenoh-client.json5"),
        )
    )
    try:
        _until(lambda: "connected to router" in caplog.text, 5, "no 'connected' line")
        figures = bus.link()
        assert figures is not None and figures.connected and figures.losses == 0
        bus.publish("test/router-link/unheard", b"")  # a publisher nobody subscribes to
        outlet = bus._outlets["test/router-link/unheard"]
        assert outlet._redeclare_ns is None

        router.close()  # type: ignore[attr-defined]
        _until(lambda: "lost router" in caplog.text, 5, "no 'lost router' line")
        lost = bus.link()
        assert lost is not None and not lost.connected and lost.losses == 1
        assert any(
            r.levelno == logging.WARNING and "lost router" in r.message for r in caplog.records
        )

        time.sleep(1.0)
        router = _router(port)
        reopened = time.monotonic()
        _until(lambda: "regained after" in caplog.text, 5, "no 'regained' line")
        # The shipped client config retries every 0.5 s at most.
        assert time.monotonic() - reopened < 1.5
        back = bus.link()
        assert back is not None and back.connected and back.losses == 1
        assert back.offline_s >= 1.0
        # The publisher was told: its gate opens for a grace, then it looks again (issue #28).
        assert outlet._redeclare_ns is not None
    finally:
        await bus.close()
        router.close()  # type: ignore[attr-defined]


async def test_a_router_session_has_no_router_to_lose(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="facesynth.link")
    port = _free_port()
    router_bus = ZenohBus.open(
        ZenohOptions(mode="router", listen=[f"tcp/127.0.0.1:{port}"], config_file=None)
    )
    client = ZenohBus.open(ZenohOptions(mode="client", connect=[f"tcp/127.0.0.1:{port}"]))
    try:
        assert router_bus.link() is None
        _until(lambda: "client" in caplog.text and "connected" in caplog.text, 5, caplog.text)
    finally:
        await client.close()
        _until(lambda: "disconnected" in caplog.text, 5, "the router logs the client leaving")
        await router_bus.close()
