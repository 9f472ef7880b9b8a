"""The ``facesynth`` command: one sub-command per service, plus run, router, status, track, bench.

Every service command takes the standard Zenoh options (``--mode``, ``--connect``, ``--listen``,
``--zenoh-config`` or ``ZENOH_CONFIG``, ``--scouting``) and ``--rig``. Errors in options or files
are printed as one clear line and exit with status 2.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Callable, Sequence
from typing import Any

from facesynth import __version__

Handler = Callable[[argparse.Namespace], int]


def _zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("Zenoh")
    group.add_argument(
        "--rig",
        default=os.environ.get("FACESYNTH_RIG", "default"),
        help="rig name: keys are facesynth/<rig>/<stage> (default: $FACESYNTH_RIG or 'default')",
    )
    group.add_argument(
        "--mode",
        choices=("peer", "client", "router"),
        help="Zenoh session mode (default: client of the router; run: router)",
    )
    group.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="endpoint to connect to, e.g. tcp/192.168.1.10:7447 "
        "(repeatable; default tcp/127.0.0.1:7447)",
    )
    group.add_argument(
        "--listen", action="append", metavar="ENDPOINT", help="endpoint to listen on (repeatable)"
    )
    group.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="Zenoh JSON5 config file (default: $ZENOH_CONFIG); options above override it",
    )
    group.add_argument(
        "--scouting",
        action="store_true",
        help="enable multicast scouting "
        "(off by default: sessions meet only the endpoints they are given)",
    )
    group.add_argument(
        "--stats-interval",
        type=float,
        default=1.0,
        metavar="S",
        help="seconds between stats messages (default 1)",
    )
    group.add_argument("--log-level", default="INFO", choices=("DEBUG", "INFO", "WARNING", "ERROR"))


def _source_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("frame source (sensor)")
    group.add_argument(
        "--video", metavar="PATH", help="video file (default: the bundled performer video)"
    )
    group.add_argument("--camera", type=int, metavar="N", help="camera index (one-frame buffer)")
    group.add_argument("--images", metavar="DIR", help="folder of images, in name order")
    group.add_argument(
        "--ticks", type=int, metavar="N", help="N frames without pixels (clock for replays)"
    )
    group.add_argument("--fps", type=float, help="frame rate override (images/ticks default 30)")
    group.add_argument("--loop", action="store_true", help="loop the video or image folder")
    group.add_argument(
        "--fast",
        action="store_true",
        help="as fast as the chain takes frames, none lost (default: real time)",
    )
    group.add_argument(
        "--window",
        type=int,
        default=2,
        help="--fast: frames in flight ahead of the last servo command (default 2)",
    )
    group.add_argument(
        "--encoding",
        choices=("jpeg", "raw"),
        default="jpeg",
        help="frame encoding on the bus (default jpeg)",
    )
    group.add_argument("--quality", type=int, default=90, help="JPEG quality 1-100 (default 90)")
    group.add_argument("--max-frames", type=int, metavar="N", help="stop after N frames")


def _points_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("point streamer")
    group.add_argument(
        "--openface-csv",
        metavar="PATH",
        help="replay OpenFace 2 CSV landmarks (row n answers frame n)",
    )
    group.add_argument("--points-jsonl", metavar="PATH", help="replay a facesynth track file")
    group.add_argument(
        "--loop-replay",
        action="store_true",
        help="loop the replayed points instead of reporting no face past their end",
    )
    group.add_argument(
        "--inference",
        choices=("auto", "litert", "opencv"),
        default="auto",
        help="tracker inference backend (default auto: LiteRT when installed)",
    )
    group.add_argument(
        "--threads", type=int, default=1, help="tracker inference threads (default 1)"
    )
    group.add_argument(
        "--select",
        choices=("largest", "score"),
        default="largest",
        help="several faces: follow the largest (default) or best-scoring one, then stick to it",
    )
    group.add_argument(
        "--redetect-every",
        type=int,
        default=30,
        metavar="N",
        help="while tracking, re-check with the face detector every N frames (default 30)",
    )


def _mapping_arguments(
    parser: argparse.ArgumentParser, *, profile: bool, calibration: bool, neutral: bool
) -> None:
    group = parser.add_argument_group("mapping")
    if profile:
        group.add_argument(
            "--profile", default="paper16", help="robot profile name or TOML path (default paper16)"
        )
        group.add_argument(
            "--mirror",
            action="store_true",
            help="mirror the performer (robot's right follows the performer's left)",
        )
    if calibration:
        group.add_argument(
            "--calibration", metavar="NAME|PATH", help="performer calibration (neutral + ranges)"
        )
    if neutral:
        group.add_argument(
            "--auto-range",
            action="store_true",
            help="without a calibration: adapt the neutral (rolling median) and the feature "
            "ranges (slowly decaying extremes) to the running stream",
        )
        group.add_argument(
            "--neutral-seconds",
            type=float,
            metavar="S",
            help="without a calibration: seconds of face used as neutral (default: profile's, 1 s)",
        )


def _driver_arguments(parser: argparse.ArgumentParser, *, default_out: str | None) -> None:
    group = parser.add_argument_group("control interface")
    group.add_argument(
        "--driver", default="record", choices=("record",), help="servo driver (default record)"
    )
    group.add_argument(
        "--out",
        default=default_out,
        metavar="FILE",
        help="record driver: JSON-lines output"
        + (f" (default {default_out})" if default_out else ""),
    )
    group.add_argument(
        "--driver-config",
        metavar="FILE",
        help="driver settings from a TOML/JSON file (overrides --driver)",
    )
    group.add_argument(
        "--watchdog",
        type=float,
        default=0.5,
        metavar="S",
        help="seconds without commands before the face returns to neutral (default 0.5)",
    )


def _queue_argument(parser: argparse.ArgumentParser, default: int) -> None:
    parser.add_argument(
        "--queue",
        type=int,
        default=default,
        help=f"input queue length; 1 = latest only (default {default})",
    )


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser."""
    from facesynth.app import commands

    parser = argparse.ArgumentParser(
        prog="facesynth",
        description="Real-time facial expression synthesis for robot and virtual faces.",
    )
    parser.add_argument("--version", action="version", version=f"facesynth {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name: str, handler: Handler, help_text: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(handler=handler)
        return p

    p = add(
        "run",
        commands.cmd_run,
        "run the whole chain (S → P → F → T → C) in one process on an embedded Zenoh router",
    )
    _source_arguments(p)
    _points_arguments(p)
    _mapping_arguments(p, profile=True, calibration=True, neutral=True)
    _driver_arguments(p, default_out="facesynth-commands.jsonl")
    _zenoh_arguments(p)
    p.add_argument(
        "--drain-timeout",
        type=float,
        default=3.0,
        help="seconds to wait for the last command after the input ends",
    )

    p = add(
        "sensor",
        commands.cmd_sensor,
        "S: publish frames from a video, camera or image folder on …/input",
    )
    _source_arguments(p)
    p.add_argument(
        "--wait-for",
        action="append",
        metavar="SERVICES",
        help="wait until these services are alive before sending, "
        "e.g. points,features,translator,control",
    )
    p.add_argument(
        "--wait-timeout",
        type=float,
        default=30.0,
        help="seconds to wait for --wait-for (default 30)",
    )
    _zenoh_arguments(p)

    p = add(
        "points",
        commands.cmd_points,
        "P: publish face landmarks on …/points (tracker, or a replayed recording)",
    )
    _points_arguments(p)
    _queue_argument(p, 2)
    _zenoh_arguments(p)

    p = add("features", commands.cmd_features, "F: publish pose-free features on …/features")
    _mapping_arguments(p, profile=False, calibration=True, neutral=True)
    _queue_argument(p, 8)
    _zenoh_arguments(p)

    p = add(
        "translator",
        commands.cmd_translator,
        "T: publish servo positions on …/servo_commands through a profile",
    )
    _mapping_arguments(p, profile=True, calibration=True, neutral=False)
    _queue_argument(p, 8)
    _zenoh_arguments(p)

    p = add("control", commands.cmd_control, "C: drive servos (or record) from …/servo_commands")
    _mapping_arguments(p, profile=True, calibration=False, neutral=False)
    _driver_arguments(p, default_out=None)
    _queue_argument(p, 8)
    _zenoh_arguments(p)

    p = add(
        "calibrate",
        commands.cmd_calibrate,
        "record a performer's neutral face and expression ranges (guided, or from a video)",
    )
    p.add_argument("name", help="calibration name (then: --calibration NAME)")
    _source_arguments(p)
    _points_arguments(p)
    p.add_argument(
        "--schedule",
        metavar="STEP=START-END,…",
        help="for a video: when each step happens, in seconds, e.g. neutral=0-2,smile=5-7",
    )
    p.add_argument(
        "--steps",
        default="neutral,raise_eyebrows,frown,look_left,look_right,look_up,look_down,"
        "raise_cheeks,open_mouth,smile",
        help="live camera: the steps to guide through, in order (default: the paper's ten)",
    )
    p.add_argument(
        "--seconds", type=float, default=4.0, help="live camera: seconds per step (default 4)"
    )
    p.add_argument("--out", help="output file (default ~/.config/facesynth/calibrations/NAME.json)")
    p.add_argument("--log-level", default="WARNING", choices=("DEBUG", "INFO", "WARNING", "ERROR"))

    p = add("router", commands.cmd_router, "run a Zenoh router (for hosts without zenohd)")
    _zenoh_arguments(p)
    p.set_defaults(mode="router")

    p = add("status", commands.cmd_status, "list live services and their stats")
    _zenoh_arguments(p)
    p.add_argument("--all-rigs", action="store_true", help="every rig, not just --rig")
    p.add_argument(
        "--timeout", type=float, default=2.5, help="seconds to listen for stats (default 2.5)"
    )

    p = add("profile", commands.cmd_profile, "list or check robot profiles")
    p.add_argument("action", choices=("list", "check", "show"))
    p.add_argument("name", nargs="?", help="profile name or TOML path (check, show)")

    p = add("bench", commands.cmd_bench, "benchmarks: the five-process chain, or the tracker")
    p.add_argument("what", choices=("chain", "tracker", "smoothing", "recording"))
    p.add_argument("video", nargs="?", help="video (default: the bundled performer video)")
    p.add_argument(
        "--seconds", type=float, default=15.0, help="chain: seconds of real-time input (default 15)"
    )
    p.add_argument(
        "--fps", type=float, default=30.0, help="chain, recording: frame rate (default 30)"
    )
    p.add_argument(
        "--openface-csv", metavar="PATH", help="chain: replay these landmarks instead of tracking"
    )
    p.add_argument(
        "--frames", type=int, help="tracker: frames to measure (default: the whole video)"
    )
    p.add_argument(
        "--encoding", choices=("jpeg", "raw"), default="jpeg", help="chain: frame encoding"
    )
    p.add_argument("--threads", type=int, default=1, help="chain: tracker inference threads")
    p.add_argument("--profile", default="paper16", help="smoothing: profile to measure")
    p.add_argument(
        "--track", help="smoothing: a facesynth track file to measure tracking noise from"
    )
    p.add_argument(
        "--mode", choices=("client", "peer"), default="client", help="chain: Zenoh mode of services"
    )
    p.add_argument(
        "--backends", default="litert,opencv", help="tracker: inference backends to compare"
    )
    p.add_argument(
        "--minutes", type=float, default=10.0, help="recording: session length (default 10)"
    )

    p = add(
        "track", commands.cmd_track, "track a video offline: one JSON line of landmarks per frame"
    )
    p.add_argument("video")
    p.add_argument("--out", required=True, help="output JSON-lines file")
    p.add_argument("--inference", choices=("auto", "litert", "opencv"), default="auto")

    from facesynth.app.recording.cli import add_recording_parsers

    add_recording_parsers(sub, _zenoh_arguments)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``facesynth`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=getattr(args, "log_level", "INFO"),
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
        stream=sys.stderr,
    )
    handler: Any = args.handler
    try:
        return int(handler(args))
    except ValueError as exc:  # every facesynth error about options, files and messages
        print(f"facesynth {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # the reader went away (e.g. `| head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
