"""A chain run by a command in one process (``run``, ``replay --graph``): its stages on a
router embedded in the process, with the attachments the command line asks for (the recorder,
the Foxglove live view), until the input ends (then drained) or a signal comes."""

from __future__ import annotations

import argparse

from facesynth.app.chain import ChainResult, freeze_startup_objects, run_chain
from facesynth.app.engine.router import RUN_LISTEN, embedded_bus
from facesynth.app.recording.attach import attached
from facesynth.app.wiring import StageParts, zenoh_options
from facesynth.runtime.bus.zenoh_bus import endpoints
from facesynth.runtime.service import run_async


def run_embedded_chain(args: argparse.Namespace, rig: str, parts: list[StageParts]) -> ChainResult:
    """Run ``parts`` on an embedded router as ``args`` say (``--listen``, ``--connect``, the
    Zenoh options, ``--drain-timeout``, ``--stats-interval``, ``--record``, ``--foxglove``)."""
    listen = endpoints(args.listen) or [RUN_LISTEN]
    options = zenoh_options(args, default_mode="router")
    options.connect = endpoints(args.connect)

    async def main() -> ChainResult:
        async with embedded_bus(listen, options, rig=rig, fallback=not args.listen) as (bus, _):
            freeze_startup_objects()
            async with attached(bus, rig, args):
                return await run_chain(
                    bus,
                    rig,
                    parts,
                    drain_timeout=args.drain_timeout,
                    stats_interval=args.stats_interval,
                )

    return run_async(main())
