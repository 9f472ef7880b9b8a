"""What a stopped subscriber does to a publisher and to the other subscribers, over Zenoh.

A real loopback router, a *hung* subscriber process (SIGSTOPped: it never reads its socket), a
healthy subscriber, and a publisher sending frame-sized messages at a steady rate. Shared memory
is off, as between hosts or containers, so every byte goes through the router's TCP links.
Used by ``test_publish_congestion.py``; run it to compare facesynth's bus with a ``BLOCK``
publisher side by side::

    .venv/bin/python tests/bus/congestion_probe.py [--frames 400] [--rate 200] [--size 50000]
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from pathlib import Path

import zenoh

from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions, open_session, router_locators

KEY = "probe/congestion/frames"
#: Sessions of this probe: no shared memory (as between hosts), no multicast scouting.
NO_SHM = "{ transport: { shared_memory: { enabled: false } } }\n"
#: Facesynth's own bus, or a raw Zenoh publisher with BLOCK congestion control (for comparison).
PUBLISHERS = ("bus", "block")


@dataclass
class Figures:
    """One run: how long ``publish`` took, and what each subscriber saw."""

    publisher: str
    sent: int
    seconds: float
    put_median_us: float
    put_max_s: float
    loop_lag_max_s: float
    healthy_received: int
    healthy_gap_max_s: float
    hung_received: int

    def line(self) -> str:
        return (
            f"{self.publisher:>5}: {self.sent} sent in {self.seconds:.2f} s; publish median "
            f"{self.put_median_us:.0f} us, max {self.put_max_s * 1e3:.1f} ms; event loop "
            f"stalled up to {self.loop_lag_max_s * 1e3:.1f} ms; healthy subscriber got "
            f"{self.healthy_received}, longest gap {self.healthy_gap_max_s * 1e3:.0f} ms; "
            f"hung subscriber got {self.hung_received} after SIGCONT"
        )


class _Counter:
    """Follows the count the hung subscriber process prints."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.count = 0
        assert process.stdout is not None
        self._thread = threading.Thread(target=self._follow, args=(process.stdout,), daemon=True)
        self._thread.start()

    def _follow(self, stream: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            if line.strip().isdigit():
                self.count = int(line)


Publish = Callable[[bytes], None]
Close = Callable[[], Awaitable[None]]


def _publisher(kind: str, options: ZenohOptions) -> tuple[Publish, Close]:
    """A publish function and its closer, for facesynth's bus or a BLOCK publisher."""
    if kind == "bus":
        bus = ZenohBus.open(options)
        return (lambda payload: bus.publish(KEY, payload)), bus.close
    session = open_session(options)
    publisher = session.declare_publisher(KEY, congestion_control=zenoh.CongestionControl.BLOCK)

    async def close() -> None:
        publisher.undeclare()
        await asyncio.to_thread(session.close)

    return publisher.put, close


async def measure(
    publisher: str = "bus", *, frames: int = 400, rate: float = 200.0, size: int = 50_000
) -> Figures:
    """Publish ``frames`` messages of ``size`` bytes at ``rate``/s while one subscriber is hung."""
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "no-shm.json5"
        config.write_text(NO_SHM)
        router = open_session(
            ZenohOptions(mode="router", listen=["tcp/127.0.0.1:0"], config_file=str(config))
        )
        try:
            return await _measure(publisher, router, str(config), frames, rate, size)
        finally:
            await asyncio.to_thread(router.close)


async def _measure(
    kind: str, router: zenoh.Session, config: str, frames: int, rate: float, size: int
) -> Figures:
    locator = router_locators(router)[0]
    client = ZenohOptions(mode="client", connect=[locator], config_file=config)
    hung = subprocess.Popen(
        [sys.executable, __file__, "subscriber", locator, config],
        stdout=subprocess.PIPE,
        text=True,
    )
    healthy = ZenohBus.open(client)
    publish, close_publisher = _publisher(kind, client)
    arrivals: list[int] = []

    async def read() -> None:
        async for sample in healthy.subscribe_queued(KEY, 64):
            arrivals.append(sample.t_received_ns)

    reader = asyncio.create_task(read())
    lag = 0.0

    async def heartbeat() -> None:
        nonlocal lag
        while True:
            before = time.perf_counter()
            await asyncio.sleep(0.005)
            lag = max(lag, time.perf_counter() - before - 0.005)

    beat: asyncio.Task[None] | None = None
    try:
        assert hung.stdout is not None
        if hung.stdout.readline().strip() != "ready":
            raise RuntimeError("the subscriber process did not start")
        hung_count = _Counter(hung)
        await asyncio.sleep(0.5)  # declarations reach the router
        hung.send_signal(signal.SIGSTOP)
        beat = asyncio.create_task(heartbeat())
        payload = os.urandom(size)
        durations: list[float] = []
        start = time.perf_counter()
        for index in range(frames):
            delay = start + index / rate - time.perf_counter()
            await asyncio.sleep(max(0.0, delay))
            before = time.perf_counter()
            publish(payload)
            durations.append(time.perf_counter() - before)
        seconds = time.perf_counter() - start
        await asyncio.sleep(0.5)
        hung.send_signal(signal.SIGCONT)
        await asyncio.sleep(1.0)  # the hung one drains what reached it
        gaps = [b - a for a, b in itertools.pairwise(arrivals)]
        return Figures(
            publisher=kind,
            sent=frames,
            seconds=seconds,
            put_median_us=statistics.median(durations) * 1e6,
            put_max_s=max(durations),
            loop_lag_max_s=lag,
            healthy_received=len(arrivals),
            healthy_gap_max_s=max(gaps, default=0) / 1e9,
            hung_received=hung_count.count,
        )
    finally:
        if beat is not None:
            beat.cancel()
        hung.send_signal(signal.SIGCONT)
        hung.kill()
        hung.wait()
        reader.cancel()
        await close_publisher()
        await healthy.close()


def _subscriber(locator: str, config: str) -> None:
    """The subscriber process: counts what it gets and prints the count every 50 ms."""
    session = open_session(ZenohOptions(mode="client", connect=[locator], config_file=config))
    count = 0

    def on_sample(sample: zenoh.Sample) -> None:
        nonlocal count
        count += 1

    session.declare_subscriber(KEY, on_sample)
    print("ready", flush=True)
    for _ in range(1200):  # a minute at most
        time.sleep(0.05)
        print(count, flush=True)
    os._exit(0)  # never wait on Zenoh's threads at interpreter exit


def main() -> None:
    if sys.argv[1:2] == ["subscriber"]:
        _subscriber(sys.argv[2], sys.argv[3])
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=400)
    parser.add_argument("--rate", type=float, default=200.0)
    parser.add_argument("--size", type=int, default=50_000)
    args = parser.parse_args()
    print(
        f"{args.frames} messages of {args.size} bytes at {args.rate:g}/s, one subscriber "
        "SIGSTOPped, one healthy, loopback router, no shared memory"
    )
    for kind in PUBLISHERS:
        figures = asyncio.run(measure(kind, frames=args.frames, rate=args.rate, size=args.size))
        print(figures.line())


if __name__ == "__main__":
    main()
