"""``facesynth router``: a Zenoh router in Python (for hosts without zenohd)."""

from __future__ import annotations

import argparse
import asyncio
import logging

from facesynth.app import wiring
from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import zenoh_arguments
from facesynth.app.tuning import (
    ROUTER_TRIM_RISE,
    ROUTER_TRIM_THRESHOLD,
    Scheduling,
    apply_scheduling,
    keep_buffers,
)
from facesynth.runtime.bus.router_options import router_options
from facesynth.runtime.bus.zenoh_bus import open_session, router_locators
from facesynth.runtime.heap_trim import HeapTrimmer
from facesynth.runtime.service import run_async, until_signalled

log = logging.getLogger("facesynth")


def cmd_router(args: argparse.Namespace) -> int:
    """``facesynth router``: a Zenoh router in Python."""
    keep_buffers(ROUTER_TRIM_THRESHOLD)
    request = Scheduling(args.nice, args.realtime, tuple(args.cpus or ()))
    if request.requested:
        apply_scheduling(request)
    options = router_options(wiring.zenoh_options(args, default_mode="router"))
    options.mode = "router"
    if not options.listen and options.config_file_path() is None:
        options.listen = ["tcp/0.0.0.0:7447"]

    async def main() -> None:
        session = await asyncio.to_thread(open_session, options)
        trimmer = HeapTrimmer(rise_bytes=ROUTER_TRIM_RISE)
        trimmer.start()
        try:
            print(
                f"facesynth router {session.info.zid()} listening on "
                f"{', '.join(router_locators(session))}",
                flush=True,
            )
            await until_signalled(asyncio.Event().wait())
        finally:
            trimmer.stop()
            await asyncio.to_thread(session.close)

    run_async(main())
    return 0


HELP = "run a Zenoh router (for hosts without zenohd)"


def _arguments(p: argparse.ArgumentParser) -> None:
    zenoh_arguments(p)
    group = p.add_argument_group("scheduling (as a node's realtime, nice, cpus)")
    group.add_argument(
        "--realtime",
        type=int,
        metavar="PRIORITY",
        help="real-time priority (SCHED_FIFO 1-99; needs CAP_SYS_NICE or ulimit -r)",
    )
    group.add_argument("--nice", type=int, help="niceness -20..19 (negative needs CAP_SYS_NICE)")
    group.add_argument(
        "--cpus",
        type=lambda text: [int(cpu) for cpu in text.split(",") if cpu.strip()],
        metavar="0,1",
        help="cores the router may run on",
    )


COMMANDS = (Command("router", HELP, cmd_router, _arguments, defaults={"mode": "router"}),)
