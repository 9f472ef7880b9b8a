"""The live page's server: static files, a WebSocket per page, and what it shows from the rig.

Built on aiohttp (imported here only: the ``[face]`` extra). Each page gets a
:class:`~services.control.drivers.virtual.fanout.Mailbox` and a writer task of its own; the
driver and the rig feed only offer messages, so no page ever slows the chain. With a
:class:`~facesynth.runtime.rig_view.RigView`, the server also follows the rig: the performer's
frames and landmarks (subscribed only while a page wants them, latest-only, so a board serving
the page pulls no frames when nobody watches) and every service's stats.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from typing import Any

from aiohttp import WSCloseCode, WSMsgType, web

from facesynth.runtime import codec, keys
from facesynth.runtime.bus.base import Subscription
from facesynth.runtime.rig_view import RigView
from facesynth.runtime.tasks import stop_tasks
from facesynth.runtime.web_app import add_page_files, close_sockets, serve_app, static_files
from facesynth.schemas.messages import Frame, Points, ServiceStats
from facesynth.services.control.drivers.virtual import wire
from facesynth.services.control.drivers.virtual.fanout import Fanout, Mailbox

log = logging.getLogger("facesynth.control.virtual")

STATIC = {
    "/": ("index.html", "text/html"),
    "/face.js": ("face.js", "text/javascript"),
    "/link.js": ("link.js", "text/javascript"),  # these four: the rig console's too
    "/frames.js": ("frames.js", "text/javascript"),
    "/bars.js": ("bars.js", "text/javascript"),
    "/stages.js": ("stages.js", "text/javascript"),
    "/face.css": ("face.css", "text/css"),
}
#: Seconds between the page's status updates.
STATS_EVERY_S = 1.0


class PageServer:
    """Serves the page on ``host:port`` and fans messages out to every open page."""

    def __init__(
        self,
        host: str,
        port: int,
        hello: str,
        *,
        rig: RigView | None = None,
        frames: bool = True,
        max_clients: int = 16,
    ) -> None:
        self.host = host
        self.port = port
        self.hello = hello
        self.rig = rig
        self.frames = frames and rig is not None
        self.max_clients = max_clients
        self.fanout = Fanout()
        self.refused = 0
        self.rejected_input = 0
        self.connections = 0
        self._last_face: str | None = None
        self._last_stats: str | None = None
        self._board = wire.StatusBoard()
        self._wanted = asyncio.Event()
        self._sockets: set[web.WebSocketResponse] = set()
        self._tasks: list[asyncio.Task[None]] = []
        self._following: dict[str, Subscription] = {}
        self._runner: web.AppRunner | None = None
        self._files = static_files("facesynth.services.control.drivers.virtual", STATIC)

    @property
    def url(self) -> str:
        """The page's address."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    async def start(self) -> None:
        """Listen (``OSError`` if the address cannot be used) and start following the rig."""
        app = web.Application()
        add_page_files(app, self._files)
        app.router.add_get("/ws", self._websocket)
        app.router.add_get("/state", self._state)
        self._runner, self.port = await serve_app(app, self.host, self.port)
        if self.rig is not None:
            self._tasks.append(asyncio.create_task(self._follow_stats(), name="page-stats"))
            self._tasks.append(asyncio.create_task(self._send_stats(), name="page-status"))
            if self.frames:
                for stage in ("input", "points"):
                    self._tasks.append(
                        asyncio.create_task(self._follow(stage), name=f"page-{stage}")
                    )

    async def stop(self) -> None:
        """Close every page's connection (they reconnect to the next server) and stop."""
        try:
            await stop_tasks(self._tasks)
        finally:  # the pages told and the server stopped even when this stop is cancelled
            self._tasks.clear()
            await close_sockets(self._sockets, b"server stopping")
            if self._runner is not None:
                await self._runner.cleanup()
                self._runner = None

    def publish_face(self, message: str) -> None:
        """Offer one command to every page (never waits)."""
        self._last_face = message
        self.fanout.offer("face", message)

    # --- HTTP --------------------------------------------------------------------------------

    async def _state(self, request: web.Request) -> web.Response:
        return web.json_response(self.state())

    def state(self) -> dict[str, Any]:
        """Counters for tests and monitoring."""
        return {
            "clients": len(self.fanout.clients),
            "connections": self.connections,
            "offered": self.fanout.offered,
            "dropped": self.fanout.dropped,
            "refused": self.refused,
            "rejected_input": self.rejected_input,
            "follows_frames": self._wanted.is_set(),
        }

    # --- WebSocket ---------------------------------------------------------------------------

    async def _websocket(self, request: web.Request) -> web.StreamResponse:
        origin = request.headers.get("Origin")
        if origin is not None and origin.split("://", 1)[-1] != request.host:
            # Another site open in the same browser must not read the performer's frames.
            return web.Response(status=403, text="cross-origin page refused")
        if len(self.fanout.clients) >= self.max_clients:
            return web.Response(status=503, text=f"{self.max_clients} pages are open already")
        ws = web.WebSocketResponse(
            max_msg_size=wire.MAX_CLIENT_MESSAGE, heartbeat=10.0, compress=False, timeout=1.0
        )
        await ws.prepare(request)
        self.connections += 1
        self._sockets.add(ws)
        mailbox = self.fanout.add(self.frames)
        self._update_demand()
        try:
            async with mailbox.sending(ws, "page-writer"):
                await ws.send_str(self.hello)
                for channel, last in (("face", self._last_face), ("stats", self._last_stats)):
                    if last is not None:
                        mailbox.offer(channel, last)
                await self._read(ws, mailbox)
        except (ConnectionError, RuntimeError):
            pass
        finally:
            self.fanout.remove(mailbox)
            self._sockets.discard(ws)
            self._update_demand()
            if not ws.closed:
                with contextlib.suppress(Exception):
                    await ws.close()
        return ws

    async def _read(self, ws: web.WebSocketResponse, mailbox: Mailbox) -> None:
        """A page's messages until it leaves; anything malformed closes its connection."""
        async for msg in ws:
            if msg.type == WSMsgType.TEXT:
                try:
                    message = wire.parse_client(msg.data)
                except wire.ClientMessageError as exc:
                    self._refuse(str(exc))
                    await ws.close(code=WSCloseCode.POLICY_VIOLATION, message=b"malformed message")
                    return
                if isinstance(message, wire.Hello):
                    mailbox.frames = message.frames and self.frames
                    self._update_demand()
                else:
                    mailbox.offer("pong", wire.pong(message))
            elif msg.type == WSMsgType.BINARY:
                self._refuse(f"binary message of {len(msg.data)} bytes")
                await ws.close(code=WSCloseCode.UNSUPPORTED_DATA, message=b"text messages only")
                return
            elif msg.type == WSMsgType.ERROR:  # e.g. larger than max_msg_size: closed with 1009
                self._refuse(str(msg.data))
                return

    def _refuse(self, reason: str) -> None:
        self.refused += 1
        if self.refused <= 10 or self.refused % 100 == 0:
            log.warning("refused a page's message (%d so far): %s", self.refused, reason)

    # --- following the rig ---------------------------------------------------------------

    def _update_demand(self) -> None:
        if self.fanout.wants_frames():
            self._wanted.set()
            return
        self._wanted.clear()
        for subscription in list(self._following.values()):
            subscription.close()  # its follower goes back to waiting for a page that wants it

    async def _follow(self, stage: keys.Stage) -> None:
        """Forward the newest frame or points to the pages, subscribed only while wanted."""
        assert self.rig is not None
        while True:
            await self._wanted.wait()
            subscription = self.rig.latest(stage)
            self._following[stage] = subscription
            try:
                async for sample in subscription:  # ends when the last page stops watching
                    self._forward(stage, sample.payload)
            finally:
                subscription.close()
                self._following.pop(stage, None)

    def _forward(self, stage: keys.Stage, payload: bytes) -> None:
        try:
            if stage == "input":
                message = wire.frame(codec.decode(payload, Frame))
                if message is not None:
                    self.fanout.offer("frame", message)
            else:
                self.fanout.offer("points", wire.points(codec.decode(payload, Points)))
        except ValueError:
            self.rejected_input += 1

    async def _follow_stats(self) -> None:
        """Keep every service's newest stats."""
        assert self.rig is not None
        subscription = self.rig.stats()
        try:
            async for sample in subscription:
                try:
                    self._board.update(codec.decode(sample.payload, ServiceStats), time.time_ns())
                except ValueError:
                    self.rejected_input += 1
        finally:
            subscription.close()

    async def _send_stats(self) -> None:
        """The status table to every page, every second."""
        while True:
            await asyncio.sleep(STATS_EVERY_S)
            self._last_stats = self._board.message(time.time_ns())
            self.fanout.offer("stats", self._last_stats)
