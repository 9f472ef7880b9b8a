"""``facesynth bench robot``: its options checked, the heads opened, the result printed."""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
from collections.abc import Callable
from pathlib import Path

import msgspec

from facesynth.app.wiring import OptionError
from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.outputs import check_output
from facesynth.runtime.profiles import Profile

from .robot import (
    DEFAULT_PROFILES,
    Head,
    RobotBench,
    RobotError,
    bench_robot,
    measure,
    track_performer,
)
from .robot_compare import FeatureStream
from .robot_report import format_robot, robot_json


def simulated_heads(names: list[str] | None) -> tuple[list[str], Callable[[str], Head]]:
    """The heads to drive (default: every bundled simulated head), each checked now, and a
    function building a fresh one by name."""
    from facesynth.app.simhead import SimHead, head_names, load_head

    chosen = names or head_names()
    configs = {name: load_head(name) for name in chosen}  # a clear error before any tracking
    return chosen, lambda name: SimHead(configs[name])


def profiles_of(args: argparse.Namespace) -> list[str]:
    """``--profile`` (repeated) and ``--profiles A,B``, in order; default the hand-written."""
    chosen = list(args.profile or [])
    chosen += [p.strip() for p in (args.profiles or "").split(",") if p.strip()]
    return chosen or list(DEFAULT_PROFILES)


def bench_robot_command(args: argparse.Namespace) -> int:
    """Every profile on every simulated head in process, or (``--driver``, ``--camera``) on a
    head outside it in real time; a table (or ``--json``) on stdout."""
    from facesynth.app.data import sample_video
    from facesynth.runtime.profiles import load_profile

    if args.frames is not None and args.frames < 1:
        raise OptionError("--frames must be at least 1")
    if args.json not in (None, "-"):
        check_output(Path(args.json), "JSON")  # before any tracking
    profiles = profiles_of(args)
    for name in profiles:
        try:
            load_profile(name)  # before any tracking
        except ValueError as exc:
            raise RobotError(f"--profile {name}: {exc}") from None
    live = args.driver is not None or args.camera is not None

    def progress(what: str) -> None:
        print(f"bench robot: {what}", file=sys.stderr, flush=True)

    if live:
        result = _live(args, profiles, progress)
    else:
        if args.port is not None:
            raise OptionError("--port goes with --driver (a head outside this process)")
        heads, open_head = simulated_heads(args.head)
        progress("tracking the performer")
        performance = track_performer(args.video or str(sample_video()), frames=args.frames)
        result = bench_robot(performance, heads, profiles, open_head, progress=progress)
    text = json.dumps(robot_json(result), indent=2)
    if args.json == "-":
        print(text)
        return 0
    if args.json:
        write_atomic(args.json, text + "\n", mode=0o644)
    print(format_robot(result))
    return 0


def driver_config(name: str, port: str | None) -> msgspec.Struct:
    """``--driver NAME [--port PORT]`` as a checked driver config."""
    from facesynth.services.control.drivers.registry import DRIVERS

    data = {"driver": name} if port is None else {"driver": name, "port": port}
    return DRIVERS.parse(data, "--driver")


def camera_config(value: str) -> msgspec.Struct:
    """``--camera VALUE`` as a checked config of the camera source (its ``--camera`` field)."""
    from facesynth.services.sensor.sources.registry import SOURCES

    plugin = SOURCES.get("camera")
    for field in plugin.fields():
        meta = field.type
        if isinstance(meta, msgspec.inspect.Metadata) and (meta.extra or {}).get("flag") == (
            "--camera"
        ):
            return SOURCES.parse({"source": "camera", field.name: value}, "--camera")
    raise OptionError("--camera: the camera source has no --camera field")  # pragma: no cover


def _live(
    args: argparse.Namespace, profiles: list[str], progress: Callable[[str], None]
) -> RobotBench:
    """Every profile on the head behind ``--driver``, watched through ``--camera``."""
    from facesynth.app.data import sample_video
    from facesynth.services.control.drivers.registry import DRIVERS
    from facesynth.services.sensor.sources.registry import SOURCES

    from .robot_live import CameraFeed, live_profile

    if args.driver is None or args.camera is None:
        raise OptionError("a head outside this process needs both --driver and --camera")
    if args.head:
        raise OptionError("--head names a simulated head in process; with --driver, omit it")
    driver = driver_config(args.driver, args.port)
    camera = camera_config(args.camera)
    feed = CameraFeed(SOURCES.build(camera))  # a camera that cannot open: before any tracking
    try:
        progress("tracking the performer")
        performance = track_performer(args.video or str(sample_video()), frames=args.frames)
        name = f"{args.driver} {args.port or ''} | camera {args.camera}".replace("  ", " ")

        def run(head: str, profile: Profile) -> FeatureStream:
            output = DRIVERS.build(driver, profile)
            return asyncio.run(live_profile(performance, profile, output, feed))

        return measure(performance, [name], profiles, run, progress=progress)
    finally:
        feed.close()
