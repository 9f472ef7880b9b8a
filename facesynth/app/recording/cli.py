"""The ``record``, ``replay``, ``inspect`` and ``convert`` sub-commands.

Registered in ``COMMANDS`` (:mod:`facesynth.app.command_registry`). Their handlers import the
``[record]`` extra (mcap, foxglove-sdk) only when they run, so every other command works
without it, and a missing extra is one clear error line.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import zenoh_arguments
from facesynth.app.recording import RECORDABLE, REPLAYABLE
from facesynth.app.recording.extra import need_record_extra
from facesynth.runtime.bus.zenoh_bus import endpoints

#: The stages a replay can feed, in chain order.
DOWNSTREAM = ("points", "features", "translator", "control")


def _record_arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth record``."""
    p.add_argument(
        "--out",
        metavar="SESSION.mcap",
        help="the recording; with --check: where a recovered copy goes",
    )
    p.add_argument(
        "--check", metavar="FILE", help="say what FILE holds; recover what a torn FILE still has"
    )
    p.add_argument(
        "--keys",
        metavar="LIST",
        help=f"comma-separated, from {','.join(RECORDABLE)} (default: all)",
    )
    p.add_argument(
        "--frame-every",
        type=int,
        default=1,
        metavar="N",
        help="record every Nth frame; 0 = no frames (default 1)",
    )
    p.add_argument(
        "--duration", type=float, metavar="S", help="stop after S seconds (default: until Ctrl-C)"
    )
    p.add_argument(
        "--chunk-mb", type=float, default=1.0, metavar="MB", help="chunk size (default 1)"
    )
    p.add_argument(
        "--chunk-seconds",
        type=float,
        default=1.0,
        metavar="S",
        help="cut a chunk at least every S seconds: a kill loses at most that (default 1)",
    )
    p.add_argument(
        "--compression",
        choices=("zstd", "lz4", "none"),
        default="zstd",
        help="chunk compression (default zstd)",
    )
    p.add_argument(
        "--no-fsync",
        action="store_true",
        help="do not fsync each chunk "
        "(a kill still loses only the last chunk; a power cut may lose more)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing file")
    zenoh_arguments(p)


def _replay_arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth replay``."""
    p.add_argument("session", metavar="SESSION.mcap")
    p.add_argument(
        "--from",
        dest="from_stage",
        choices=REPLAYABLE,
        help="stage to replay (default: the earliest recorded)",
    )
    pace = p.add_mutually_exclusive_group()
    pace.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="X",
        help="timing factor: 2 = twice as fast (default 1)",
    )
    pace.add_argument(
        "--fast", action="store_true", help="as fast as the chain takes it, nothing lost"
    )
    p.add_argument(
        "--window",
        type=int,
        default=2,
        help="--fast: messages in flight ahead of the last servo command (default 2)",
    )
    p.add_argument(
        "--restamp",
        action="store_true",
        help="set capture times to the replay's clock (latencies read as live)",
    )
    p.add_argument(
        "--wait-for",
        action="append",
        metavar="SERVICES",
        help="wait until these services are alive, e.g. features,translator,control",
    )
    p.add_argument(
        "--wait-timeout",
        type=float,
        default=30.0,
        help="seconds to wait for --wait-for (default 30)",
    )
    graph = p.add_argument_group("through a graph, in this process")
    graph.add_argument(
        "--graph",
        nargs="?",
        const="",
        metavar="FILE",
        help="run the graph's nodes after the replayed stage here, on an embedded router "
        "(no FILE: the demo graph); their flags below override the file",
    )
    graph.add_argument(
        "--drain-timeout",
        type=float,
        default=3.0,
        help="--graph: seconds to wait for the last command after the replay ends",
    )
    from facesynth.app.recording.attach import add_attach_arguments
    from facesynth.app.stage_args import add_stage_arguments

    add_stage_arguments(p, DOWNSTREAM)
    add_attach_arguments(p)
    zenoh_arguments(p)


def _inspect_arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth inspect``."""
    p.add_argument(
        "--foxglove",
        default="127.0.0.1:8765",
        metavar="HOST:PORT",
        help="where to listen (default 127.0.0.1:8765; port 0: any free port)",
    )
    p.add_argument(
        "--frame-every", type=int, default=1, metavar="N", help="show every Nth frame (default 1)"
    )
    zenoh_arguments(p)


def _convert_arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth convert``."""
    p.add_argument("input", help="an OpenFace .csv, a facesynth track .jsonl, or a recording .mcap")
    p.add_argument(
        "output",
        help=".mcap (from landmarks); .jsonl (record driver lines) or .csv (from a recording)",
    )
    p.add_argument(
        "--stage",
        choices=("servo_state", "servo_commands", "features"),
        help="what to export (default servo_state, else servo_commands)",
    )
    p.add_argument(
        "--rig", default="default", help="landmarks: rig of the recorded keys (default 'default')"
    )
    p.add_argument("--fps", type=float, default=30.0, help="landmarks: frame rate (default 30)")
    p.add_argument(
        "--size", default="640x480", help="landmarks: image size WIDTHxHEIGHT (default 640x480)"
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing .mcap output")
    p.add_argument(
        "--to",
        choices=("rosbag2",),
        help="rosbag2: a recording to a rosbag2 folder OUTPUT/ that ROS 2 tools play "
        "(JointState, CompressedImage, Float32MultiArray; MCAP, CDR)",
    )
    p.add_argument(
        "--profile",
        help="--to rosbag2: the profile whose angle maps give the radians (default: the one "
        "the commands name)",
    )


def _zenoh(args: argparse.Namespace) -> Any:
    from facesynth.app import wiring

    return wiring.zenoh_options(args)


def cmd_record(args: argparse.Namespace) -> int:
    """``facesynth record``."""
    need_record_extra()
    if args.check:
        return _check(args)
    from facesynth.app.chain import run_single
    from facesynth.app.recording.layout import LAYOUT_VERSION
    from facesynth.app.recording.recorder import (
        Recorder,
        RecordOptionError,
        RecordOptions,
        parse_keys,
    )
    from facesynth.app.recording.writer import SessionWriter
    from facesynth.runtime import keys
    from facesynth.runtime.service import run_async

    if not args.out:
        raise RecordOptionError("give --out SESSION.mcap (or --check FILE)")
    rig = args.rig or "default"
    keys.check_name(rig)
    options = RecordOptions(
        keys=parse_keys(args.keys), frame_every=args.frame_every, duration=args.duration
    )
    zenoh = _zenoh(args)
    metadata = {
        "rig": rig,
        "keys": ",".join(options.keys),
        "frame_every": str(options.frame_every),
        "started_ns": str(time.time_ns()),
        "layout": LAYOUT_VERSION,
    }
    if not args.chunk_mb > 0:
        raise RecordOptionError("--chunk-mb must be positive")
    writer = SessionWriter(
        args.out,
        metadata=metadata,
        chunk_bytes=max(1024, int(args.chunk_mb * 2**20)),
        chunk_seconds=args.chunk_seconds,
        compression=args.compression,
        fsync=not args.no_fsync,
        overwrite=args.overwrite,
    )
    recorder = Recorder(writer, options)
    recorded = False
    try:
        run_async(
            run_single(zenoh, rig, "record", recorder.serve, stats_interval=args.stats_interval)
        )
        recorded = True
    finally:
        writer.close()
        if not recorded and writer.messages == 0:  # e.g. no router: leave no empty session
            writer.path.unlink(missing_ok=True)
    summary = {
        "out": str(writer.path),
        "messages": sum(recorder.recorded.values()),
        "by_key": dict(sorted(recorder.recorded.items())),
        "frames_thinned": recorder.thinned,
        "kept_verbatim": sum(recorder.layout.raw.values()),
        "refused_disk_too_slow": recorder.refused,
        "chunks": writer.chunks,
    }
    print(json.dumps(summary))
    return 0


def _check(args: argparse.Namespace) -> int:
    from facesynth.app.recording.check import describe, recover, scan
    from facesynth.app.recording.reader import RecordingError

    path = Path(args.check)
    result = scan(path)
    if not result.facesynth:
        raise RecordingError(
            f"{path} is an MCAP file but not a facesynth recording (profile {result.profile!r}, "
            f"written by {result.library!r})"
        )
    print(describe(result))
    if result.complete:
        return 0
    out = Path(args.out) if args.out else path.with_name(path.stem + ".recovered.mcap")
    if out.exists() and not args.overwrite:
        raise RecordingError(
            f"{out} exists (give --overwrite to replace it, or --out another file)"
        )
    recovered = recover(path, out)
    print(
        f"recovered {recovered.messages} messages from {recovered.chunks} intact chunks into {out}"
    )
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    """``facesynth replay``."""
    need_record_extra()
    from facesynth.app.chain import run_single
    from facesynth.app.graph import wait_for_problem
    from facesynth.app.recording.reader import Recording
    from facesynth.app.recording.replay import (
        Replayer,
        ReplayLinkError,
        ReplayOptionError,
        ReplayOptions,
    )
    from facesynth.runtime.service import run_async

    problem = wait_for_problem(endpoints(args.wait_for))
    if problem:
        raise ReplayOptionError(problem)
    options = ReplayOptions(
        stage=args.from_stage,
        speed=args.speed,
        fast=args.fast,
        window=args.window,
        restamp=args.restamp,
        wait_for=endpoints(args.wait_for),
        wait_timeout=args.wait_timeout,
    )
    rig = args.rig or "default"
    chain: dict[str, Any] = {}
    with Recording(args.session) as recording:
        replayer = Replayer(recording, options)
        started = time.monotonic()
        if args.graph is not None:
            from facesynth.app.recording.through_graph import replay_through_graph

            outcome, rig, chain = replay_through_graph(replayer, args)
        else:
            zenoh = _zenoh(args)
            outcome = run_async(
                run_single(zenoh, rig, "replay", replayer.serve, stats_interval=args.stats_interval)
            )
    summary = {
        "session": args.session,
        "stage": replayer.stage,
        "rig": rig,
        "published": replayer.published,
        "last_seq": replayer.last_seq,
        "seconds": round(time.monotonic() - started, 2),
        "stalls": replayer.stalls,
        **chain,
    }
    if replayer.link.losses:
        summary["sent_without_router"] = replayer.link.unlinked
        summary["router_losses"] = replayer.link.losses
    print(json.dumps(summary), flush=True)
    if outcome is None:
        return 130  # interrupted: the summary says what the lost router cost, if anything
    problem = replayer.link.problem(replayer.sent)
    if problem is not None:
        raise ReplayLinkError(problem)
    return 0


def cmd_inspect(args: argparse.Namespace) -> int:
    """``facesynth inspect``."""
    need_record_extra()
    from facesynth.app.chain import run_single
    from facesynth.app.recording.live import Address, FoxgloveBridge
    from facesynth.runtime import keys
    from facesynth.runtime.service import run_async

    rig = args.rig or "default"
    keys.check_name(rig)
    bridge = FoxgloveBridge(Address.parse(args.foxglove), rig=rig, frame_every=args.frame_every)
    zenoh = _zenoh(args)
    bridge.start()
    try:
        print(
            f"facesynth inspect: rig {rig} on {bridge.url} "
            "(Foxglove: Open connection, Foxglove WebSocket, this URL)",
            flush=True,
        )
        run_async(
            run_single(zenoh, rig, "inspect", bridge.serve, stats_interval=args.stats_interval)
        )
    finally:
        bridge.stop()
    return 0


def cmd_convert(args: argparse.Namespace) -> int:
    """``facesynth convert``."""
    need_record_extra()
    from facesynth.app.recording.convert import (
        ConvertError,
        export_csv,
        export_jsonl,
        landmarks_to_mcap,
        parse_size,
    )
    from facesynth.app.recording.reader import Recording

    source, target = Path(args.input), Path(args.output)
    if args.to == "rosbag2":
        from facesynth.app.recording.rosbag2 import export_rosbag2

        if source.suffix.lower() != ".mcap":
            raise ConvertError(f"{source}: --to rosbag2 converts a recording (.mcap)")
        with Recording(source) as recording:
            counts = export_rosbag2(
                recording, target, profile=args.profile, overwrite=args.overwrite
            )
        print(json.dumps({"input": str(source), "output": str(target), "topics": counts}))
        return 0
    if source.suffix.lower() == ".mcap":
        exporters = {".jsonl": export_jsonl, ".csv": export_csv}
        exporter = exporters.get(target.suffix.lower())
        if exporter is None:
            raise ConvertError(f"{target}: a recording converts to .jsonl or .csv")
        with Recording(source) as recording:
            count = exporter(recording, target, args.stage)
    else:
        if target.suffix.lower() != ".mcap":
            raise ConvertError(f"{target}: landmarks convert to a .mcap recording")
        count = landmarks_to_mcap(
            source,
            target,
            rig=args.rig or "default",
            fps=args.fps,
            size=parse_size(args.size),
            overwrite=args.overwrite,
        )
    print(json.dumps({"input": str(source), "output": str(target), "messages": count}))
    return 0


RECORD_HELP = "record a rig's keys into an MCAP session file (or --check one)"
REPLAY_HELP = "publish a recording back on a rig's keys, with its timing or --fast"
INSPECT_HELP = (
    "serve a rig live to Foxglove (WebSocket): frame with landmarks, features, servos, stats"
)
CONVERT_HELP = (
    "convert OpenFace .csv or track .jsonl to a recording, or a recording to JSON lines or CSV"
)

COMMANDS = (
    Command("record", RECORD_HELP, cmd_record, _record_arguments),
    Command("replay", REPLAY_HELP, cmd_replay, _replay_arguments),
    Command("inspect", INSPECT_HELP, cmd_inspect, _inspect_arguments),
    Command("convert", CONVERT_HELP, cmd_convert, _convert_arguments),
)
