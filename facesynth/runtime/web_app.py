"""Serving an aiohttp application on a host and port: the live face page and the simulated
head's camera share it. aiohttp is the ``[face]`` extra, imported when a server starts."""

from __future__ import annotations

from typing import Any


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
