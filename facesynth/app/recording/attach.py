"""``--foxglove`` and ``--record`` for chains run in one process (``run``, ``replay --graph``).

Both attach to the chain's own bus as extra services: a live Foxglove view of the rig, and a
recorder of every key (as ``facesynth record`` would, without a second process racing the
chain's start). The recorder is listening before the chain starts and takes the chain's last
messages before it closes the file.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator
from typing import Any

from facesynth.app.recording import RECORDABLE
from facesynth.runtime.tasks import stop_tasks

log = logging.getLogger("facesynth")

#: Default address of the live view.
FOXGLOVE_DEFAULT = "127.0.0.1:8765"


def add_attach_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare ``--foxglove [HOST:PORT]`` and ``--record SESSION.mcap``."""
    group = parser.add_argument_group("record and watch (needs the record extra)")
    group.add_argument(
        "--foxglove",
        nargs="?",
        const=FOXGLOVE_DEFAULT,
        metavar="HOST:PORT",
        help=f"serve the rig live to Foxglove over WebSocket (default {FOXGLOVE_DEFAULT})",
    )
    group.add_argument(
        "--record",
        metavar="SESSION.mcap",
        help="record every key of the rig into an MCAP session file (must not exist)",
    )


@contextlib.asynccontextmanager
async def attached(bus: Any, rig: str, args: argparse.Namespace) -> AsyncIterator[None]:
    """Run the live view and the recorder that ``args`` ask for while the block runs."""
    foxglove = getattr(args, "foxglove", None)
    record = getattr(args, "record", None)
    if not foxglove and not record:
        yield
        return
    from facesynth.app.recording.extra import need_record_extra

    need_record_extra()
    from facesynth.app.recording.live import Address, FoxgloveBridge
    from facesynth.app.recording.recorder import Recorder, RecordOptions
    from facesynth.app.recording.writer import SessionWriter
    from facesynth.runtime.service import ServiceContext, run_service

    stats_interval = getattr(args, "stats_interval", 1.0)
    tasks: list[asyncio.Task[Any]] = []
    bridge = None
    recorder = None
    try:
        if foxglove:
            bridge = FoxgloveBridge(Address.parse(foxglove), rig=rig)
            bridge.start()
            print(f"Foxglove live view of rig {rig} on {bridge.url}", flush=True)
            ctx = ServiceContext(bus, rig, "inspect", stats_interval=stats_interval)
            tasks.append(asyncio.create_task(run_service(ctx, bridge.serve), name="inspect"))
        if record:
            options = RecordOptions(list(RECORDABLE))
            recorder = Recorder(SessionWriter(record, metadata=options.metadata(rig)), options)
            ctx = ServiceContext(bus, rig, "record", stats_interval=stats_interval)
            tasks.append(asyncio.create_task(run_service(ctx, recorder.serve), name="record"))
            await asyncio.wait_for(recorder.listening.wait(), 10.0)
        yield
        if recorder is not None:
            await asyncio.sleep(0.3)  # the chain's last messages reach the recorder
    finally:
        try:
            await stop_tasks(tasks)
        finally:  # the file complete, the bridge closed, even when this stop is cancelled
            if recorder is not None:
                recorder.writer.close()
                log.info("recorded %d messages into %s", sum(recorder.recorded.values()), record)
            if bridge is not None:
                bridge.stop()
