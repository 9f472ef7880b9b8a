"""Helpers for the virtual driver's tests: a driver on a free port, and page clients."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import pytest

from facesynth.runtime.bus.memory import MemoryBus
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.rig_view import RigView
from facesynth.services.control.drivers.virtual import VirtualConfig, VirtualDriver


async def start_driver(
    profile: str = "virtual", bus: MemoryBus | None = None, rig: str = "r", **options: Any
) -> VirtualDriver:
    """A connected virtual driver on 127.0.0.1 (a free port unless ``http`` is given)."""
    config = VirtualConfig(**{"http": "127.0.0.1:0", **options})
    driver = VirtualDriver(config, load_profile(profile))
    if bus is not None:
        driver.observe(RigView(bus, rig))
    await driver.connect()
    return driver


@pytest.fixture
async def page_driver() -> AsyncIterator[VirtualDriver]:
    driver = await start_driver()
    try:
        yield driver
    finally:
        await driver.close()


class PageClient:
    """A page's WebSocket, read as the browser would (text as JSON, binary as frames)."""

    def __init__(self, ws: aiohttp.ClientWebSocketResponse) -> None:
        self.ws = ws

    async def collect(self, kinds: set[str], timeout: float = 5.0) -> dict[str, Any]:
        """The first message of each type in ``kinds``, whatever order they come in."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        got: dict[str, Any] = {}
        while set(got) != kinds:
            msg = await self.ws.receive(timeout=max(0.01, deadline - loop.time()))
            if msg.type == aiohttp.WSMsgType.TEXT:
                data = json.loads(msg.data)
                got.setdefault(data["type"], data)
            elif msg.type == aiohttp.WSMsgType.BINARY:
                got.setdefault("frame", msg.data)
            else:
                raise AssertionError(f"connection ended: {msg.type} {msg.data}")
        return {kind: got[kind] for kind in kinds}

    async def next(self, kind: str, timeout: float = 5.0) -> Any:
        """The next message of type ``kind`` (``frame`` for binary ones)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            msg = await self.ws.receive(timeout=max(0.01, deadline - loop.time()))
            if msg.type == aiohttp.WSMsgType.TEXT:
                data = json.loads(msg.data)
                if data["type"] == kind:
                    return data
            elif msg.type == aiohttp.WSMsgType.BINARY:
                if kind == "frame":
                    return msg.data
            else:
                raise AssertionError(f"connection ended waiting for {kind}: {msg.type} {msg.data}")


async def open_page(
    session: aiohttp.ClientSession, driver: VirtualDriver, frames: bool = True, **kwargs: Any
) -> PageClient:
    ws = await session.ws_connect(driver.url + "ws", **kwargs)
    await ws.send_str(json.dumps({"type": "hello", "frames": frames}))
    return PageClient(ws)
