"""Serving an aiohttp application on a host and port: the live face page, the rig console and
the simulated head's camera share it; the two pages share how their files are served and how
their WebSockets are closed. aiohttp is the ``[face]`` extra, imported when a server starts."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Iterable
from importlib import resources
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aiohttp import web


async def serve_app(app: Any, host: str, port: int) -> tuple[Any, int]:
    """Run ``app`` (an ``aiohttp.web.Application``) on ``host:port`` (0: a free port).

    Returns its runner (``await runner.cleanup()`` stops it) and the port it listens on.
    Raises ``OSError`` when the address cannot be used, with nothing left running.
    """
    from aiohttp import web

    runner = web.AppRunner(app, handle_signals=False, access_log=None, shutdown_timeout=1.0)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    try:
        await site.start()
    except BaseException:
        await runner.cleanup()
        raise
    sockets = getattr(site._server, "sockets", None)
    if port == 0 and sockets:
        port = sockets[0].getsockname()[1]
    return runner, port


def static_files(package: str, files: dict[str, tuple[str, str]]) -> dict[str, tuple[bytes, str]]:
    """A page's files, read from ``package``'s ``static`` folder: ``{url path: (file name,
    content type)}`` → ``{url path: (bytes, content type)}``."""
    folder = resources.files(package) / "static"
    return {
        path: (folder.joinpath(name).read_bytes(), kind) for path, (name, kind) in files.items()
    }


def add_page_files(app: web.Application, files: dict[str, tuple[bytes, str]]) -> None:
    """Serve a page's files on ``app``, each at its path (``GET``: never cached, so a restarted
    server's page is the one loaded, and taken as its declared type only), and no icon (204)."""
    from aiohttp import web

    headers = {"Cache-Control": "no-store", "X-Content-Type-Options": "nosniff"}

    async def page_file(request: web.Request) -> web.Response:
        body, kind = files[request.path]
        return web.Response(body=body, content_type=kind, charset="utf-8", headers=headers)

    async def no_icon(request: web.Request) -> web.Response:
        return web.Response(status=204)

    for path in files:
        app.router.add_get(path, page_file)
    app.router.add_get("/favicon.ico", no_icon)


async def close_sockets(sockets: Iterable[Any], message: bytes) -> None:
    """Close each of a stopping server's WebSockets as going away (1001, with ``message``),
    waiting at most a second for each (a page then reconnects by itself)."""
    from aiohttp import WSCloseCode

    for ws in list(sockets):
        with contextlib.suppress(Exception):
            async with asyncio.timeout(1.0):
                await ws.close(code=WSCloseCode.GOING_AWAY, message=message)
