"""Whether the router still holds a session's declarations, and declaring them anew if not.

Issue #28, seen in the lab (real stages, loopback router, the deploy/ settings, a machine at a
load average of 25): a stage connected to a live router, its link up and keep-alives flowing
both ways, whose router held none of its declarations (no subscription, no liveliness token).
It received nothing and nobody heard it, for as long as that link lasted (57 s in a soak, until
the next router kill), and no transport event told it. Cutting that link made the stage rejoin
with everything and its stream came back at once.

A Zenoh bus of a client session holding a liveliness token (every service does; the deploy/
configs are clients) asks the router's admin space every :data:`CHECK_S` whether the router
lists the session as that token's holder (``@/*/router/token/KEY``), else as a subscriber (a
second opinion); peers are not checked. A question whose answers did not all come back within
its timeout gives no verdict. The question used to be a liveliness query for the token (two
answers for a client's own token, the session's and the router's; one meaning lost): in soaks
of 2026-11-27 the sensor (a publisher only, no subscription to vouch for it) read as lost about
once a minute while its stream flowed and an independent client, asking the same router every
second, saw its token throughout (21 false alarms in 31 minutes at load 5-10; none in the 72
minutes of soak after this change). Two noes in a row,
or :data:`SILENT_LIMIT` questions in a row without a verdict (a router that no longer answers
this session at all), and the bus declares every subscription, publisher and token anew
(:meth:`facesynth.runtime.bus.zenoh_bus.ZenohBus.declare_anew`), at most once every
:data:`ANEW_EVERY_S`, so a router that keeps answering no costs a declaration a
half-minute, not a storm.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from collections.abc import Callable
from typing import Any, Final

log = logging.getLogger("facesynth.link")

#: How often a bus asks whether its router holds its liveliness token.
CHECK_S: Final = 2.0
#: How long one question waits for its answers (a timeout gives no verdict).
QUERY_TIMEOUT_S: Final = 1.0
#: A router's admin space entry listing the sessions holding a liveliness token (+ its key).
ADMIN_TOKENS: Final = "@/*/router/token/"
#: A router's admin space entries listing the sessions subscribed to each key expression.
ADMIN_SUBSCRIBERS: Final = "@/*/router/subscriber/**"
#: Declared anew at most this often, whatever the answers (a router that keeps saying no).
ANEW_EVERY_S: Final = 30.0
#: This many questions in a row without a verdict while linked count as one no.
SILENT_LIMIT: Final = 5


def router_holds(session: Any, key: str, timeout: float = QUERY_TIMEOUT_S) -> bool | None:
    """Whether the router holds ``session``'s declarations: its admin space lists the session
    as a holder of ``key``, a liveliness token of the session, or else as a subscriber (a
    second opinion before declaring everything anew). ``None`` when a question timed out (no
    verdict: an answer may still have been on its way). Blocks up to twice ``timeout``."""
    try:
        zid = str(session.info.zid())
        for question in (ADMIN_TOKENS + key, ADMIN_SUBSCRIBERS):
            started = time.monotonic()
            for reply in session.get(question, timeout=timeout):
                if reply.ok is not None and zid in json.loads(reply.ok.payload.to_bytes()).get(
                    "clients", []
                ):
                    return True
            if time.monotonic() - started >= timeout:
                return None  # cut off by the timeout, not told "that is all" by the router
    except Exception:  # the session is closing, or an admin answer is not JSON: no verdict
        return None
    return False


async def watch(
    ask: Callable[[], bool | None],
    connected: Callable[[], bool],
    declare_anew: Callable[[], None],
) -> None:
    """Every :data:`CHECK_S`, while ``connected()``: ``ask()`` whether the router holds the
    session's token (in a worker thread); after two noes in a row (or :data:`SILENT_LIMIT`
    questions in a row without a verdict, counted as one no), ``declare_anew()``, at most once
    every :data:`ANEW_EVERY_S`."""
    noes = silent = 0
    last_ns: int | None = None
    while True:
        await asyncio.sleep(CHECK_S)
        if not connected():
            noes = silent = 0
            continue
        held = await asyncio.to_thread(ask)
        if held is None:
            silent += 1
            if silent < SILENT_LIMIT:
                continue
            held = False
        silent = 0
        if held:
            noes = 0
            continue
        noes += 1
        now = time.monotonic_ns()
        if noes < 2 or (last_ns is not None and now - last_ns < ANEW_EVERY_S * 1e9):
            continue
        log.warning(
            "the router holds none of this session's declarations (its liveliness token is "
            "unknown there) though the link is up: declaring every subscription, publisher "
            "and token anew"
        )
        declare_anew()
        noes, last_ns = 0, now
