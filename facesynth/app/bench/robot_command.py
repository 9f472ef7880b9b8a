"""``facesynth bench robot``: its options checked, the heads opened, the result printed."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable

from facesynth.app.wiring import OptionError

from .robot import DEFAULT_PROFILES, Head, RobotError, bench_robot, track_performer
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
    """Every profile on every simulated head, in process; a table (or ``--json``) on stdout."""
    from facesynth.app.data import sample_video
    from facesynth.runtime.profiles import load_profile

    if args.frames is not None and args.frames < 1:
        raise OptionError("--frames must be at least 1")
    profiles = profiles_of(args)
    for name in profiles:
        try:
            load_profile(name)  # before any tracking
        except ValueError as exc:
            raise RobotError(f"--profile {name}: {exc}") from None
    heads, open_head = simulated_heads(args.head)

    def progress(what: str) -> None:
        print(f"bench robot: {what}", file=sys.stderr, flush=True)

    progress("tracking the performer")
    performance = track_performer(args.video or str(sample_video()), frames=args.frames)
    result = bench_robot(performance, heads, profiles, open_head, progress=progress)
    if args.json:
        print(json.dumps(robot_json(result), indent=2))
    else:
        print(format_robot(result))
    return 0
