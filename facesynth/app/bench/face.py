"""``facesynth bench face``: what the live face page costs the control service, per page.

The ``virtual`` driver runs in this process on loopback and takes commands at a fixed rate, as
C would give them; the pages are WebSocket clients in another process (so they cost this one
nothing, as browsers would), reading everything, or stalled (a page that stops reading: its
socket fills, then only its own mailbox). Each row reports the driver's ``send`` time (what the
chain waits for) and this process's CPU time per command (geometry, encoding, fan-out and the
pages' writers), beside the ``record`` driver, the cheapest output there is.
"""

from __future__ import annotations

import asyncio
import logging
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import ServoDriver
from facesynth.services.control.drivers.record import RecordConfig, RecordDriver

#: The pages: a script run with ``python -c``, given the URL, readers and stalled pages.
PAGES = """
import asyncio, sys, aiohttp
async def main(url, readers, stalled):
    counts = [0] * readers
    async def read(i, ws):
        async for msg in ws:
            counts[i] += 1
    async with aiohttp.ClientSession() as session:
        sockets = [await session.ws_connect(url) for _ in range(readers + stalled)]
        tasks = [asyncio.create_task(read(i, ws)) for i, ws in enumerate(sockets[:readers])]
        print("ready", flush=True)
        await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
        print(" ".join(map(str, counts)) or "-", flush=True)
        for task in tasks:
            task.cancel()
asyncio.run(main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3])))
"""

FRAME_BYTES = 40_000  # a 640x360 JPEG at quality 90 is about this size


@dataclass
class Case:
    """One row: the driver, pages reading, pages stalled, a frame with every command."""

    name: str
    driver: str = "virtual"
    readers: int = 0
    stalled: int = 0
    frames: bool = False


CASES = [
    Case("record driver (baseline)", driver="record"),
    Case("virtual, no page"),
    Case("virtual, 1 page", readers=1),
    Case("virtual, 4 pages", readers=4),
    Case("virtual, 16 pages", readers=16),
    Case("virtual, 4 pages + frames", readers=4, frames=True),
    Case("virtual, 4 pages + frames + 1 stalled", readers=4, stalled=1, frames=True),
]


async def _pages(url: str, readers: int, stalled: int) -> asyncio.subprocess.Process:
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-c", PAGES, url, str(readers), str(stalled),
        stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE,
    )  # fmt: skip
    assert process.stdout is not None
    line = await asyncio.wait_for(process.stdout.readline(), 30)
    if line.strip() != b"ready":
        raise RuntimeError("the bench's pages did not start (is aiohttp installed?)")
    return process


async def _run_case(case: Case, seconds: float, rate: float, folder: str) -> dict[str, Any]:
    from facesynth.services.control.drivers.virtual import VirtualConfig, VirtualDriver

    profile = load_profile("virtual")
    driver: ServoDriver
    if case.driver == "record":
        driver = RecordDriver(RecordConfig(out=os.path.join(folder, "bench.jsonl")), profile)
    else:
        driver = VirtualDriver(VirtualConfig(http="127.0.0.1:0"), profile)
    await driver.connect()
    pages = None
    try:
        if isinstance(driver, VirtualDriver) and (case.readers or case.stalled):
            pages = await _pages(driver.url + "ws", case.readers, case.stalled)
            await asyncio.sleep(0.3)
            if case.frames and driver.server is not None:
                for mailbox in driver.server.fanout.clients:  # as pages showing the performer
                    mailbox.frames = True
        neutral = profile.neutral_positions()
        frame = b"\xff" * FRAME_BYTES
        count = round(seconds * rate)
        timings = np.empty(count)
        loop = asyncio.get_running_loop()
        start, cpu = loop.time(), time.process_time()
        for i in range(count):
            positions = {
                **neutral,
                "jaw": 500 + 400 * math.sin(i / 10),
                "brow_left": 300.0 + i % 400,
            }
            t0 = time.perf_counter()
            await driver.send(positions, CommandInfo(i, None, True))
            timings[i] = time.perf_counter() - t0
            if case.frames and isinstance(driver, VirtualDriver) and driver.server is not None:
                driver.server.fanout.offer("frame", frame)
            await asyncio.sleep(max(0.0, start + (i + 1) / rate - loop.time()))
        await asyncio.sleep(0.2)  # let the writers finish
        cpu_per_command = (time.process_time() - cpu) / count
        received = None
        dropped = 0
        if isinstance(driver, VirtualDriver) and driver.server is not None:
            dropped = driver.server.state()["dropped"]
        if pages is not None and pages.stdin is not None and pages.stdout is not None:
            pages.stdin.write(b"\n")
            await pages.stdin.drain()
            counts = (await asyncio.wait_for(pages.stdout.readline(), 10)).split()
            received = min((int(c) for c in counts if c != b"-"), default=None)
    finally:
        if pages is not None:
            if pages.returncode is None:
                pages.kill()
            await pages.wait()
        await driver.close()
    return {
        "case": case.name,
        "commands": count,
        "send_p50_us": float(np.percentile(timings, 50) * 1e6),
        "send_p99_us": float(np.percentile(timings, 99) * 1e6),
        "cpu_us_per_command": cpu_per_command * 1e6,
        "min_received": received,
        "dropped": dropped,
    }


def bench_face(seconds: float = 3.0, rate: float = 100.0) -> dict[str, Any]:
    """Run every case; ``rate`` commands per second for ``seconds`` each."""

    logging.getLogger("facesynth.control").setLevel(logging.WARNING)

    async def main() -> list[dict[str, Any]]:
        with tempfile.TemporaryDirectory() as folder:
            return [await _run_case(case, seconds, rate, folder) for case in CASES]

    return {"seconds": seconds, "rate": rate, "rows": asyncio.run(main())}


def format_face(result: dict[str, Any]) -> str:
    """The table."""
    lines = [
        f"live face page: {result['rate']:g} commands/s for {result['seconds']:g} s per row; "
        "pages in another process",
        f"{'case':<40} {'send p50 µs':>11} {'send p99 µs':>11} {'CPU µs/cmd':>10} "
        f"{'page got':>8} {'dropped':>7}",
    ]
    for row in result["rows"]:
        got = "-" if row["min_received"] is None else str(row["min_received"])
        lines.append(
            f"{row['case']:<40} {row['send_p50_us']:>11.0f} {row['send_p99_us']:>11.0f} "
            f"{row['cpu_us_per_command']:>10.0f} {got:>8} {row['dropped']:>7}"
        )
    lines.append(
        "page got: messages the slowest reading page received (faces, frames); dropped: messages "
        "replaced in a mailbox before they could be sent (a stalled page's, mostly)"
    )
    return "\n".join(lines)
