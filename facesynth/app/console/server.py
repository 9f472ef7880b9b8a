"""The console's web server: the page, one WebSocket per page, and two HTTP actions.

Same conventions as the live face page (:mod:`facesynth.services.control.drivers.virtual.server`):
aiohttp, static files with ``no-store``, a WebSocket that the page reconnects by itself, the
stage table from every service's stats, the performer's frames and landmarks. On top:

* **a token**, printed at start and carried in the page's URL (``#token=…``, never sent in a
  request line): a page says it in its ``hello``; without it a page only watches. Everything
  that moves a servo or writes a file needs it (``POST /api/stop`` and ``/api/save`` take it
  in the ``X-Facesynth-Token`` header);
* **a lock**: the first page with the token that moves a servo holds the servos until it lets
  go or closes; another page (another tab, another browser) is refused, clearly, meanwhile;
* **same origin only**: a WebSocket or POST whose ``Origin`` is not this server is refused
  (403), and so is a request whose ``Host`` is not this server's loopback name while it
  listens on loopback (a DNS-rebinding page cannot reach it either).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
import time
from collections.abc import Callable
from typing import Any

import msgspec
from aiohttp import WSCloseCode, WSMsgType, web

from facesynth.app.console import protocol as p
from facesynth.app.console.calibration import CalibrationRun
from facesynth.app.console.page import Page
from facesynth.app.console.rig import ConsoleError
from facesynth.app.console.session import ConsoleSession
from facesynth.runtime.web_app import add_page_files, close_sockets, serve_app, static_files
from facesynth.services.control.drivers.virtual import wire

log = logging.getLogger("facesynth.console")

STATIC = {
    "/": ("index.html", "text/html"),
    "/console.js": ("console.js", "text/javascript"),
    "/console.css": ("console.css", "text/css"),
}
#: The live face page's files the console's page uses too (its WebSocket, the performer's
#: frames, the servos' bars, the stage table).
FACE_PAGE_STATIC = {
    "/link.js": ("link.js", "text/javascript"),
    "/frames.js": ("frames.js", "text/javascript"),
    "/bars.js": ("bars.js", "text/javascript"),
    "/stages.js": ("stages.js", "text/javascript"),
}
LOOPBACK = {"127.0.0.1", "localhost", "::1"}
TOKEN_HEADER = "X-Facesynth-Token"


class ConsoleServer:
    """Serves the console for one :class:`ConsoleSession` on ``host:port``."""

    def __init__(
        self,
        session: ConsoleSession,
        *,
        host: str = "127.0.0.1",
        port: int = 8095,
        token: str | None = None,
        calibration: Callable[[str], CalibrationRun] | None = None,
        max_pages: int = 8,
        views: dict[str, str] | None = None,
    ) -> None:
        self.session = session
        self.host = host
        self.port = port
        self.token = token or secrets.token_urlsafe(18)
        self.calibration = calibration
        self.max_pages = max_pages
        self.views = dict(views or {})
        self.pages: dict[web.WebSocketResponse, Page] = {}
        self.owner: Page | None = None
        self.refused = 0
        self.calibrating: CalibrationRun | None = None
        self._board = wire.StatusBoard()
        self._notes: dict[tuple[str, str], str] = {}
        self._runner: web.AppRunner | None = None
        self._tasks: list[asyncio.Task[Any]] = []
        self._files = static_files("facesynth.app.console", STATIC) | static_files(
            "facesynth.services.control.drivers.virtual", FACE_PAGE_STATIC
        )

    @property
    def url(self) -> str:
        """The page's address, with the token (give it to the browser as it is)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/#token={self.token}"

    async def start(self) -> None:
        """Listen (``OSError`` if the address cannot be used) and relay what the session sees."""
        app = web.Application(client_max_size=p.MAX_MESSAGE)
        add_page_files(app, self._files)
        app.router.add_get("/ws", self._websocket)
        app.router.add_get("/state", self._state)
        app.router.add_post("/api/stop", self._http_stop)
        app.router.add_post("/api/save", self._http_save)
        self.session.listener = self._on_event
        self._runner, self.port = await serve_app(app, self.host, self.port)
        self._tasks.append(asyncio.create_task(self._send_stats(), name="console-table"))

    async def stop(self) -> None:
        """Close every page and stop serving."""
        if self.calibrating is not None:
            self.calibrating.cancel()
        for task in self._tasks:
            task.cancel()
        await close_sockets(self.pages, b"console stopping")
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None

    # --- checks -----------------------------------------------------------------------------

    def refusal(self, request: web.Request) -> str | None:
        """Why a request from another site (or through a foreign host name) is refused."""
        hostname = request.host.rsplit(":", 1)[0].strip("[]") if request.host else ""
        if self.host in LOOPBACK and hostname not in LOOPBACK:
            return f"host {request.host!r} is not this console (it listens on loopback)"
        origin = request.headers.get("Origin")
        if origin is not None and origin.split("://", 1)[-1] != request.host:
            return f"cross-origin request from {origin} refused"
        return None

    def _token_ok(self, given: str) -> bool:
        return secrets.compare_digest(given.encode(), self.token.encode())

    # --- HTTP -------------------------------------------------------------------------------

    async def _state(self, request: web.Request) -> web.Response:
        return web.json_response(
            {
                **self.session.state(),
                "pages": len(self.pages),
                "locked": self.owner is not None,
                "refused": self.refused,
            }
        )

    def _http_check(self, request: web.Request) -> web.Response | None:
        reason = self.refusal(request)
        if reason is not None:
            self.refused += 1
            return web.json_response({"error": reason}, status=403)
        if not self._token_ok(request.headers.get(TOKEN_HEADER, "")):
            self.refused += 1
            return web.json_response(
                {"error": f"needs the console's token in the {TOKEN_HEADER} header"}, status=401
            )
        return None

    async def _http_stop(self, request: web.Request) -> web.Response:
        refused = self._http_check(request)
        if refused is not None:
            return refused
        try:
            self.session.check_free()
        except ValueError as exc:
            return web.json_response({"error": str(exc)}, status=409)
        self.session.core.stop_all()
        return web.json_response({"ok": True, "stopped": True})

    async def _http_save(self, request: web.Request) -> web.Response:
        refused = self._http_check(request)
        if refused is not None:
            return refused
        if self.owner is not None:
            return web.json_response(
                {"error": "a console page holds the servos: save from that page"}, status=409
            )
        try:
            saved = await self.session.save()
        except ValueError as exc:
            return web.json_response({"error": str(exc)}, status=400)
        return web.json_response({"ok": True, **saved})

    # --- WebSocket ------------------------------------------------------------------------

    async def _websocket(self, request: web.Request) -> web.StreamResponse:
        reason = self.refusal(request)
        if reason is not None:
            self.refused += 1
            return web.Response(status=403, text=reason)
        if len(self.pages) >= self.max_pages:
            return web.Response(status=503, text=f"{self.max_pages} console pages are open")
        ws = web.WebSocketResponse(max_msg_size=p.MAX_MESSAGE, heartbeat=10.0, timeout=1.0)
        await ws.prepare(request)
        page = Page()
        self.pages[ws] = page
        self.session.watch(True)
        try:
            async with page.outbox.sending(ws, "console-writer"):
                page.outbox.say(self._hello())
                await self._read(ws, page)
        except (ConnectionError, RuntimeError):
            pass
        finally:
            del self.pages[ws]
            self.session.watch(any(other.outbox.frames for other in self.pages.values()))
            if self.owner is page:  # the page that held the servos is gone: let go
                self.owner = None
                self.session.core.release()
            if not ws.closed:
                with contextlib.suppress(Exception):
                    await ws.close()
        return ws

    def _hello(self) -> str:
        core = self.session.core
        return p.message(
            "hello",
            profile=core.draft.name,
            save_to=str(self.session.save_to),
            servos=core.servo_rows(),
            control=self.session.control_state,
            calibration=self.calibration is not None,
            face_page=self.views.get("face_page"),
            robot_camera=self.views.get("robot_camera"),
        )

    async def _read(self, ws: web.WebSocketResponse, page: Page) -> None:
        async for msg in ws:
            if msg.type == WSMsgType.TEXT:
                try:
                    reply = await self.handle(page, p.parse(msg.data))
                except ValueError as exc:  # MessageError, ConsoleError, ProfileError, …
                    self.refused += 1
                    reply = p.message("error", message=str(exc))
                if reply is not None:
                    page.outbox.say(reply)
            elif msg.type == WSMsgType.BINARY:
                self.refused += 1
                await ws.close(code=WSCloseCode.UNSUPPORTED_DATA, message=b"text messages only")
                return
            elif msg.type == WSMsgType.ERROR:  # larger than max_msg_size: closed with 1009
                self.refused += 1
                return

    async def handle(self, page: Page, message: p.ClientMessage) -> str | None:
        """Do what a page asks; returns the reply (``ValueError`` for a refusal)."""
        core = self.session.core
        if isinstance(message, p.Hello):
            page.outbox.frames = message.frames
            self.session.watch(any(other.outbox.frames for other in self.pages.values()))
            page.trusted = bool(message.token) and self._token_ok(message.token)
            if message.token and not page.trusted:
                raise ConsoleError("wrong token: open the address the console printed at start")
            return p.message("welcome", trusted=page.trusted)
        if isinstance(message, p.Ping):
            return p.message("pong", t=message.t)
        if not page.trusted:
            raise ConsoleError(
                "this page has no token: open the address the console printed at start "
                "(…/#token=…) to move servos or save"
            )
        if isinstance(message, p.Release):
            if self.owner is page or self.owner is None:  # (a hold of POST /api/stop too)
                self.owner = None
                core.release()
            return p.message("released")
        if isinstance(message, p.Stop):  # any trusted page may stop the servos
            self.session.check_free()
            core.stop_all()
            return None
        if isinstance(message, p.Calibrate):
            return self._calibrate(message.name)
        if self.owner is not None and self.owner is not page:
            raise ConsoleError(
                "another console page holds the servos: let go there (or close it) first"
            )
        if isinstance(message, p.Save):
            saved = await self.session.save()
            self.owner = None
            self._broadcast_hello()
            return p.message("saved", **saved)
        if isinstance(message, p.Take | p.Jog | p.Centre | p.Neutral):
            self.session.check_free()
        self.owner = page
        if isinstance(message, p.Take):
            core.hold()
        elif isinstance(message, p.Jog):
            core.jog(message.servo, message.us)
        elif isinstance(message, p.Centre):
            core.centre_all()
        elif isinstance(message, p.Neutral):
            core.neutral_all()
        else:
            self._edit(message)
            self._broadcast_hello()
        return None

    def _edit(self, message: p.ClientMessage) -> None:
        core = self.session.core
        if isinstance(message, p.SetLimit):
            core.set_limit(message.servo, message.which, message.us)
        elif isinstance(message, p.Rename):
            core.rename(message.servo, message.name)
        elif isinstance(message, p.Reverse):
            core.reverse(message.servo, message.reversed)

    def _broadcast_hello(self) -> None:
        hello = self._hello()
        for page in self.pages.values():
            page.outbox.say(hello)

    def _calibrate(self, name: str) -> str:
        if self.calibration is None:
            raise ConsoleError("no performer source: start the console with --camera N or --video")
        if self.calibrating is not None:
            raise ConsoleError(f"calibration {self.calibrating.name!r} is running")
        run = self.calibration(name)
        self.calibrating = run
        loop = asyncio.get_running_loop()

        def report(kind: str, payload: Any) -> None:
            loop.call_soon_threadsafe(self._on_event, kind, payload)

        async def calibrate() -> None:
            result: dict[str, Any]
            try:
                path = await asyncio.to_thread(run.run, report)
                result = {"state": "done", "path": str(path), "frames": run.frames_used}
            except Exception as exc:  # every failure is shown on the page, one line
                log.warning("calibration %s: %s", name, exc)
                result = {"state": "failed", "error": str(exc)}
            self.calibrating = None
            self._on_event("calibration", {"name": name, **result})

        self._tasks.append(asyncio.create_task(calibrate(), name="console-calibration"))
        return p.message("calibration", state="starting", name=name)

    # --- what the session sees ------------------------------------------------------------

    def _on_event(self, kind: str, payload: Any) -> None:
        if kind == "state":
            for page in self.pages.values():
                held = None if self.owner is None else ("you" if self.owner is page else "other")
                page.outbox.offer("state", p.message("state", **payload, held_by=held))
        elif kind == "stats":
            stats, now_ns = payload
            self._board.update(stats, now_ns)
            self._notes[(stats.service, stats.instance)] = stats.note
        elif kind == "frame":
            frame = wire.frame(payload)
            if frame is not None:
                self._offer("frame", frame)
        elif kind == "points":
            self._offer("points", wire.points(payload))
        elif kind == "control":
            self._offer("control", p.message("control", state=payload))
        elif kind == "calibration":
            message = p.message("calibration", **payload)
            for page in self.pages.values():
                if payload.get("state") == "running":  # progress: the newest is enough
                    page.outbox.offer("calibration", message)
                else:  # the end: no progress message may come after it
                    page.outbox.say(message, replaces="calibration")
        elif kind == "error":
            for page in self.pages.values():
                page.outbox.say(p.message("error", message=str(payload)))

    def _offer(self, channel: str, message: str | bytes) -> None:
        for page in self.pages.values():
            page.outbox.offer(channel, message)

    def table(self, now_ns: int) -> str:
        """The stage table for the pages: every service's figures and its note (C's says how
        its servo board is: connected, reconnecting…)."""
        rows = [
            {**msgspec.to_builtins(row), "note": self._notes.get((row.service, row.instance), "")}
            for row in self._board.rows(now_ns)
        ]
        return p.message("stats", services=rows)

    async def _send_stats(self) -> None:
        while True:
            await asyncio.sleep(1.0)
            self._offer("stats", self.table(time.time_ns()))
