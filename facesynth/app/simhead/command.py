"""``facesynth simhead``: run a simulated head as a device (Maestro on a pty, MJPEG camera).

Registered in ``COMMANDS`` (:mod:`facesynth.app.command_registry`). It prints the
serial port and the camera URL, then runs until Ctrl-C (or SIGTERM), removing its link.
"""

from __future__ import annotations

import argparse
import asyncio
import signal
import sys
from pathlib import Path
from typing import Any

from facesynth.app.command_registry import Command

__all__ = ["COMMANDS", "cmd_simhead", "parse_address"]

HELP = (
    "a simulated robot head: a face photo moved by messy actuators, speaking the Pololu "
    "Maestro protocol on a pseudo-terminal and serving its camera as an MJPEG URL"
)


def parse_address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (port 0 = any free port) as (host, port)."""
    from .server import SimHeadServerError

    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise SimHeadServerError(f"--http {text!r} is not HOST:PORT (e.g. 127.0.0.1:8090)")
    return host.strip("[]"), int(port)


def _arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth simhead``'s arguments."""
    p.add_argument(
        "head",
        nargs="?",
        default="simhead16",
        help="a bundled head (simhead16, simhead16_reversed, simhead16_stiff, simhead18_lids, "
        "simhead18_neck), a head file "
        "(TOML) or seed:N (a head generated from seed N, on head16_hardware's channels); "
        "default simhead16",
    )
    p.add_argument(
        "--serial-link",
        metavar="PATH",
        help="symlink to create to the head's serial port (a pty), e.g. /tmp/simhead-tty: "
        "give it to a driver as --port",
    )
    p.add_argument(
        "--http",
        default="127.0.0.1:8090",
        metavar="HOST:PORT",
        help="where the camera is served (default 127.0.0.1:8090; port 0 = any free port)",
    )
    p.add_argument("--fps", type=float, default=30.0, help="camera frame rate (default 30)")
    p.add_argument(
        "--noise",
        type=float,
        default=1.5,
        help="camera grain, grey levels (default 1.5; 0 = none): the tracker jitters a little, "
        "as with a real camera",
    )
    p.add_argument(
        "--channels",
        type=int,
        choices=(6, 12, 18, 24),
        default=24,
        help="the Maestro model's channel count (default 24: a Mini Maestro 24)",
    )
    p.add_argument("--list", action="store_true", help="list the bundled heads and exit")
    p.add_argument(
        "--bench",
        type=int,
        default=0,
        metavar="FRAMES",
        help="render FRAMES random poses of the head, print the time a frame takes, and exit",
    )
    p.add_argument(
        "--device-number",
        type=int,
        default=12,
        help="the Maestro's device number for the Pololu protocol (default 12)",
    )


def cmd_simhead(args: argparse.Namespace) -> int:
    """Run the simulated head until Ctrl-C."""
    from .head import SimHead
    from .heads import head_names, load_head
    from .maestro import Maestro
    from .server import SimHeadServer, SimHeadServerError

    if args.list:
        for name in head_names():
            print(f"{name}: {load_head(name).description}")
        return 0
    config = load_head(args.head)
    if args.bench:
        return _bench(config, args.bench)
    if not args.serial_link:
        raise SimHeadServerError("simhead needs --serial-link PATH (e.g. /tmp/simhead-tty)")
    host, port = parse_address(args.http)
    maestro = Maestro(channels=args.channels, device_number=args.device_number)
    server = SimHeadServer(
        SimHead(config), maestro, Path(args.serial_link), host, port, args.fps, noise=args.noise
    )
    return asyncio.run(_serve(server, config.name, len(config.actuators)))


def _bench(config: Any, frames: int) -> int:
    """Render ``frames`` random poses (pulses 1000-2000 µs, 0.1 s apart); print ms a frame."""
    import time

    import numpy as np

    from .head import SimHead
    from .renderer import default_renderer

    if frames < 1:
        raise ValueError(f"--bench {frames}: give at least 1 frame")
    start = time.perf_counter()
    renderer = default_renderer()
    built = time.perf_counter() - start
    head = SimHead(config, renderer)
    rng = np.random.default_rng(0)
    times = []
    for i in range(frames):
        for actuator in config.actuators:
            head.command(actuator.channel, float(rng.uniform(1000, 2000)))
        head.step((i + 1) * 100_000_000)
        start = time.perf_counter()
        head.render()
        times.append(time.perf_counter() - start)
    ms = np.array(times) * 1000
    print(
        f"simhead {config.name}: {frames} frames of {renderer.face.image.shape[1]}x"
        f"{renderer.face.image.shape[0]}: mean {ms.mean():.2f} ms, median {np.median(ms):.2f} ms, "
        f"p95 {np.percentile(ms, 95):.2f} ms, max {ms.max():.2f} ms a frame "
        f"(start-up: {built:.2f} s)"
    )
    return 0


async def _serve(server: Any, name: str, actuators: int) -> int:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await server.start()
    try:
        print(f"simhead: head {name} ({actuators} actuators)")
        print(
            f"serial port: {server.link} -> {server.device} "
            f"(Pololu Maestro, {server.maestro.channels} channels)"
        )
        print(f"camera: {server.url} (snapshot {server.snapshot_url})")
        print("Ctrl-C to stop", flush=True)
        sys.stdout.flush()
        await stop.wait()
    finally:
        await server.stop()
    return 0


COMMANDS = (Command("simhead", HELP, cmd_simhead, _arguments),)
