"""The bus a command's stages run on: a router embedded in the process (``run``, ``replay
--graph``, ``learn``, ``console``), or a session joining other routers and peers (a graph
without a sensor, a stage command).

Each is opened here, once, so the session's mode and the bus's idea of it cannot drift apart: a
bus over an embedded router's session reports no router link (it *is* the router), and a joined
bus reports the link it has.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from facesynth.runtime.bus.router_options import router_options
from facesynth.runtime.bus.zenoh_bus import (
    ZenohBus,
    ZenohConfigError,
    ZenohOptions,
    open_session,
    router_locators,
)
from facesynth.runtime.heap_trim import HeapTrimmer

log = logging.getLogger("facesynth")

#: Where ``facesynth run``'s own router listens when not told (``--listen``).
RUN_LISTEN = "tcp/127.0.0.1:7447"
#: Where it listens instead when :data:`RUN_LISTEN` is taken: a free port on loopback.
FREE_PORT_LISTEN = "tcp/127.0.0.1:0"


def open_embedded(
    listen: list[str], options: ZenohOptions, *, fallback: bool = True
) -> tuple[Any, list[str]]:
    """A router session listening on ``listen``, and the locators it listens on.

    With ``fallback`` (run's default endpoint, no ``--listen``) a taken endpoint is replaced by a
    free port on loopback, and said; without it (an explicit ``--listen``: other hosts may be
    told that address) a taken endpoint is an error, as ``facesynth doctor`` reports it. The
    session is configured as a router's (:mod:`facesynth.runtime.bus.router_options`)."""
    options = router_options(options)
    try:
        session = open_session(
            ZenohOptions(**{**options.__dict__, "mode": "router", "listen": listen})
        )
    except ZenohConfigError as exc:
        fallback_listen = [FREE_PORT_LISTEN]
        if not fallback or listen == fallback_listen:
            raise
        log.warning("cannot listen on %s (%s); using a free port instead", ", ".join(listen), exc)
        session = open_session(
            ZenohOptions(**{**options.__dict__, "mode": "router", "listen": fallback_listen})
        )
    return session, router_locators(session)


@asynccontextmanager
async def embedded_bus(
    listen: list[str], options: ZenohOptions, *, rig: str, fallback: bool = True
) -> AsyncIterator[tuple[ZenohBus, list[str]]]:
    """A bus over a router embedded in this process (see :func:`open_embedded`), and its
    locators; logged, and closed on the way out. While it is open, the process gives free heap
    back to the system after bursts, as ``facesynth router`` does
    (:mod:`facesynth.runtime.heap_trim`)."""
    session, locators = await asyncio.to_thread(open_embedded, listen, options, fallback=fallback)
    bus = ZenohBus(session, mode="router")
    log.info("embedded Zenoh router on %s (rig %s)", ", ".join(locators), rig)
    trimmer = HeapTrimmer()
    trimmer.start()
    try:
        yield bus, locators
    finally:
        trimmer.stop()
        await bus.close()


@asynccontextmanager
async def joined_bus(options: ZenohOptions) -> AsyncIterator[ZenohBus]:
    """A bus over a session opened from ``options`` as they say (client, peer or router),
    closed on the way out."""
    bus = await asyncio.to_thread(ZenohBus.open, options)
    try:
        yield bus
    finally:
        await bus.close()
