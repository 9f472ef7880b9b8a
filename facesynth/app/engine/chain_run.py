"""A chain run by a command in one process (``run``, ``replay --graph``): its stages on a
router embedded in the process, with the attachments the command line asks for (the recorder,
the Foxglove live view), until the input ends (then drained) or a signal comes.

The command hands its attachments in (``attach``: for ``run`` and ``replay --graph``,
:func:`facesynth.app.recording.attach.attached`), so the engine imports no feature built on it.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager
from typing import Any

from facesynth.app.chain import ChainResult, freeze_startup_objects, run_chain
from facesynth.app.engine.router import RUN_LISTEN, embedded_bus
from facesynth.app.wiring import StageParts, zenoh_options
from facesynth.runtime.bus.zenoh_bus import endpoints
from facesynth.runtime.service import run_async

#: What a command attaches to its chain's bus while the chain runs: given the bus, the rig and
#: the command line, an async context (services started on entry, finished on exit).
Attach = Callable[[Any, str, argparse.Namespace], AbstractAsyncContextManager[None]]


@contextlib.asynccontextmanager
async def nothing_attached(bus: Any, rig: str, args: argparse.Namespace) -> AsyncIterator[None]:
    """No attachment."""
    yield


def run_embedded_chain(
    args: argparse.Namespace,
    rig: str,
    parts: list[StageParts],
    attach: Attach = nothing_attached,
) -> ChainResult:
    """Run ``parts`` on an embedded router as ``args`` say (``--listen``, ``--connect``, the
    Zenoh options, ``--drain-timeout``, ``--stats-interval``), with what ``attach`` starts on
    its bus (e.g. the recorder and live view of ``--record`` and ``--foxglove``)."""
    listen = endpoints(args.listen) or [RUN_LISTEN]
    options = zenoh_options(args, default_mode="router")
    options.connect = endpoints(args.connect)

    async def main() -> ChainResult:
        async with embedded_bus(listen, options, rig=rig, fallback=not args.listen) as (bus, _):
            freeze_startup_objects()
            async with attach(bus, rig, args):
                return await run_chain(
                    bus,
                    rig,
                    parts,
                    drain_timeout=args.drain_timeout,
                    stats_interval=args.stats_interval,
                )

    return run_async(main())
