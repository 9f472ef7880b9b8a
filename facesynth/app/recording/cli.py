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
from facesynth.app.recording.arguments import (
    convert_arguments,
    inspect_arguments,
    record_arguments,
    replay_arguments,
)
from facesynth.app.recording.extra import need_record_extra
from facesynth.runtime.bus.zenoh_bus import endpoints


def _zenoh(args: argparse.Namespace) -> Any:
    from facesynth.app import wiring

    return wiring.zenoh_options(args)


def cmd_record(args: argparse.Namespace) -> int:
    """``facesynth record``."""
    need_record_extra()
    if args.check:
        return _check(args)
    from facesynth.app.chain import run_single
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
    if not args.chunk_mb > 0:
        raise RecordOptionError("--chunk-mb must be positive")
    writer = SessionWriter(
        args.out,
        metadata=options.metadata(rig),
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
                recording, target, profile=args.profile, overwrite=args.overwrite, robot=args.robot
            )
        print(json.dumps({"input": str(source), "output": str(target), "topics": counts}))
        return 0
    if source.suffix.lower() == ".mcap":
        exporters = {".jsonl": export_jsonl, ".csv": export_csv}
        exporter = exporters.get(target.suffix.lower())
        if exporter is None:
            raise ConvertError(f"{target}: a recording converts to .jsonl or .csv")
        with Recording(source) as recording:
            count = exporter(recording, target, args.stage, args.robot)
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
    Command("record", RECORD_HELP, cmd_record, record_arguments),
    Command("replay", REPLAY_HELP, cmd_replay, replay_arguments),
    Command("inspect", INSPECT_HELP, cmd_inspect, inspect_arguments),
    Command("convert", CONVERT_HELP, cmd_convert, convert_arguments),
)
