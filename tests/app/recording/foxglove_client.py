"""A small client of Foxglove's WebSocket protocol (the spec's subscribe / message data), on
aiohttp: what the Foxglove app does when it opens a live connection."""

from __future__ import annotations

import asyncio
import contextlib
import json
import struct
from typing import Any

import aiohttp

#: Offered as the Foxglove app does; the SDK's server picks ``foxglove.sdk.v1``.
SUBPROTOCOLS = ("foxglove.sdk.v1", "foxglove.websocket.v1")


class FoxgloveClient:
    """Reads the connection in the background: advertised channels, then message data."""

    def __init__(self, ws: aiohttp.ClientWebSocketResponse) -> None:
        self.ws = ws
        self.server_info: dict[str, Any] = {}
        self.channels: dict[str, dict[str, Any]] = {}
        self.subscriptions: dict[int, dict[str, Any]] = {}
        self._advertised = asyncio.Event()
        self._data: asyncio.Queue[tuple[int, int, bytes]] = asyncio.Queue()
        self._next_id = 1
        self._reader = asyncio.create_task(self._read())

    async def _read(self) -> None:
        async for message in self.ws:
            if message.type == aiohttp.WSMsgType.TEXT:
                op = json.loads(message.data)
                if op["op"] == "serverInfo":
                    self.server_info = op
                elif op["op"] == "advertise":
                    for channel in op["channels"]:
                        self.channels.setdefault(channel["topic"], channel)
                    self._advertised.set()
            elif message.type == aiohttp.WSMsgType.BINARY:
                data: bytes = message.data
                assert data[0] == 0x01, f"opcode {data[0]:#x} is not message data"
                subscription, timestamp = struct.unpack_from("<IQ", data, 1)
                self._data.put_nowait((subscription, timestamp, data[13:]))

    async def wait_for_channel(self, topic: str, timeout: float = 10.0) -> dict[str, Any]:
        """The advertisement of ``topic`` (waits for it)."""
        async with asyncio.timeout(timeout):
            while topic not in self.channels:
                self._advertised.clear()
                await self._advertised.wait()
        return self.channels[topic]

    async def subscribe(self, channel: dict[str, Any]) -> int:
        """Subscribe to an advertised channel; returns the subscription id."""
        subscription = self._next_id
        self._next_id += 1
        self.subscriptions[subscription] = channel
        request = {
            "op": "subscribe",
            "subscriptions": [{"id": subscription, "channelId": channel["id"]}],
        }
        await self.ws.send_str(json.dumps(request))
        return subscription

    async def message(self, timeout: float = 10.0) -> tuple[int, int, bytes]:
        """The next message data: (subscription id, receive timestamp ns, payload)."""
        return await asyncio.wait_for(self._data.get(), timeout)

    async def close(self) -> None:
        """Close the connection."""
        await self.ws.close()
        self._reader.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self._reader


async def connect(session: aiohttp.ClientSession, url: str) -> FoxgloveClient:
    """Open a Foxglove connection and wait for the server's info."""
    ws = await session.ws_connect(url, protocols=SUBPROTOCOLS)
    assert ws.protocol in SUBPROTOCOLS
    client = FoxgloveClient(ws)
    async with asyncio.timeout(10):
        while not client.server_info:
            await asyncio.sleep(0.01)
    return client
