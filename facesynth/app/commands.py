"""Implementations of the ``facesynth`` sub-commands (the parser lives in ``cli``)."""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from facesynth.app import wiring
from facesynth.app.chain import (
    ChainResult,
    build_chain,
    build_nodes,
    freeze_startup_objects,
    open_embedded,
    run_chain,
    run_single,
    serve_nodes,
)
from facesynth.app.compose import compose_file
from facesynth.app.graph import Graph, check_node, load_graph, select_node
from facesynth.app.nodes import NODE_TYPES, SensorNode, stage_of
from facesynth.app.plugin_help import describe_plugins
from facesynth.app.recording.attach import attached
from facesynth.app.stage_args import apply_arguments
from facesynth.app.tuning import Scheduling, apply_scheduling, combined, keep_buffers
from facesynth.app.wiring import OptionError, build_node, replay_frames_of
from facesynth.runtime import keys
from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.bus.zenoh_bus import ZenohBus, endpoints, open_session, router_locators
from facesynth.runtime.service import default_instance, run_async, until_signalled
from services.control.drivers.registry import DRIVERS

log = logging.getLogger("facesynth")


def cmd_stage(args: argparse.Namespace) -> int:
    """``facesynth sensor|points|features|translator|control``: one node as its own service."""
    stage: str = args.stage
    if getattr(args, "list_drivers", False):
        print(describe_plugins(DRIVERS))
        return 0
    if args.graph:
        graph = load_graph(args.graph, plugins=False)
        name = args.node
        node = select_node(graph, stage, name, args.graph)
        name = name or next(n for n, v in graph.nodes.items() if v is node)
    else:
        if args.node:
            raise OptionError("--node needs --graph")
        name, node = stage, NODE_TYPES[stage]()
        graph = Graph(nodes={name: node})
    node, config = apply_arguments(name, node, args)
    check_node(name, node, args.graph or "command line")
    graph.nodes[name] = node
    tune_process([node])
    replay_frames = None
    if isinstance(node, SensorNode) and args.graph:
        if not node.wait_for:  # started from a graph: wait for the graph's other stages
            others = {stage_of(n) for n in graph.nodes.values() if stage_of(n) != "sensor"}
            node.wait_for = sorted(others)
        replay_frames = replay_frames_of(graph)
    parts = build_node(name, node, graph, config, replay_frames=replay_frames)
    options = wiring.zenoh_options(args)
    rig = args.rig or graph.rig
    instance = None if name == stage else f"{default_instance()}-{name}"
    run_async(
        run_single(
            options,
            rig,
            stage,
            parts.body,
            instance=instance,
            stats_interval=args.stats_interval,
            robot=parts.robot,
        )
    )
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    """``facesynth run [GRAPH]``: every node of a graph in one process."""
    graph = load_graph(args.graph, plugins=False)
    configs = {}
    for name, node in list(graph.nodes.items()):
        graph.nodes[name], configs[name] = apply_arguments(name, node, args)
        check_node(name, graph.nodes[name], args.graph or "command line")
    rig = args.rig or graph.rig
    tune_process(graph.nodes.values())
    if not graph.of_stage("sensor"):
        return _serve_graph(args, graph, configs, rig)
    parts = build_chain(graph, configs)
    listen = endpoints(args.listen) or ["tcp/127.0.0.1:7447"]
    options = wiring.zenoh_options(args, default_mode="router")
    options.connect = endpoints(args.connect)

    async def main() -> ChainResult:
        session, locators = await asyncio.to_thread(open_embedded, listen, options)
        bus = ZenohBus(session)
        log.info("embedded Zenoh router on %s (rig %s)", ", ".join(locators), rig)
        freeze_startup_objects()
        try:
            async with attached(bus, rig, args):
                return await run_chain(
                    bus,
                    rig,
                    parts,
                    drain_timeout=args.drain_timeout,
                    stats_interval=args.stats_interval,
                )
        finally:
            await bus.close()

    result = run_async(main())
    outs = [
        getattr(configs[name], "out", configs[name].__struct_config__.tag)
        for name in graph.of_stage("control")
    ]
    summary: dict[str, Any] = {
        "frames": result.frames,
        "commands": result.commands,
        "last_frame_executed": result.last_frame,
        "seconds": round(result.seconds, 2),
        "rejected": result.rejected,
        "dropped": result.dropped,
        "out": outs[0] if len(outs) == 1 else outs,
    }
    if args.render and not result.interrupted:
        from facesynth.app.render import render_graph

        summary["render"] = render_graph(graph, configs, args.render)
    print(json.dumps(summary))
    return 130 if result.interrupted else 0


def _serve_graph(args: argparse.Namespace, graph: Graph, configs: dict[str, Any], rig: str) -> int:
    """``facesynth run`` of a graph without a sensor: its nodes (say, a robot host's translators
    and control interfaces) in one process, fed from the bus, until a signal arrives.

    As a router by default (listening where ``run`` does); ``--mode client|peer`` joins the
    router or peers given by ``--connect`` instead, like a stage command; exits 0 when
    signalled, as a stage command does."""
    parts = build_nodes(graph, configs)
    options = wiring.zenoh_options(args, default_mode="router")
    if options.mode == "router" and not options.listen and options.config_file_path() is None:
        options.listen = ["tcp/127.0.0.1:7447"]

    async def main() -> ChainResult:
        bus = ZenohBus(await asyncio.to_thread(open_session, options))
        log.info("%d nodes of %s on rig %s", len(parts), args.graph, rig)
        freeze_startup_objects()
        try:
            return await serve_nodes(bus, rig, parts, stats_interval=args.stats_interval)
        finally:
            await bus.close()

    result = run_async(main())
    print(
        json.dumps(
            {
                "nodes": [part.name for part in parts],
                "commands": result.commands,
                "seconds": round(result.seconds, 2),
                "rejected": result.rejected,
                "dropped": result.dropped,
            }
        )
    )
    return 0  # like a stage command, it ends when told to


def cmd_render(args: argparse.Namespace) -> int:
    """``facesynth render [GRAPH] --out OUT.mp4``: the side-by-side video of a graph's input."""
    from facesynth.app.render import render_graph

    graph = load_graph(args.graph, plugins=False)
    configs = {}
    for name, node in list(graph.nodes.items()):
        if stage_of(node) == "control":
            del graph.nodes[name]
            continue
        graph.nodes[name], configs[name] = apply_arguments(name, node, args)
    summary = render_graph(graph, configs, args.out, bars=args.bars, same_size=args.same_size)
    print(json.dumps(summary))
    return 0


def cmd_compose(args: argparse.Namespace) -> int:
    """``facesynth compose GRAPH``: the docker-compose file for a graph."""
    text = compose_file(load_graph(args.graph), args.graph, graph_path=args.graph_path)
    if args.out:
        write_atomic(Path(args.out), text.encode())
    else:
        print(text, end="")
    return 0


def tune_process(nodes: Iterable[Any]) -> None:
    """Set this process up for the nodes it runs: buffer reuse, and their scheduling requests
    (the most demanding of each kind, see :mod:`facesynth.app.tuning`)."""
    keep_buffers()
    request = combined(Scheduling(node.nice, node.realtime, tuple(node.cpus)) for node in nodes)
    if request.requested:
        apply_scheduling(request)
        log.info("scheduling: %s", request.describe())


def cmd_router(args: argparse.Namespace) -> int:
    """``facesynth router``: a Zenoh router in Python."""
    keep_buffers()
    request = Scheduling(args.nice, args.realtime, tuple(args.cpus or ()))
    if request.requested:
        apply_scheduling(request)
    options = wiring.zenoh_options(args, default_mode="router")
    options.mode = "router"
    if not options.listen and options.config_file_path() is None:
        options.listen = ["tcp/0.0.0.0:7447"]

    async def main() -> None:
        session = await asyncio.to_thread(open_session, options)
        try:
            print(
                f"facesynth router {session.info.zid()} listening on "
                f"{', '.join(router_locators(session))}",
                flush=True,
            )
            await until_signalled(asyncio.Event().wait())
        finally:
            await asyncio.to_thread(session.close)

    run_async(main())
    return 0


def cmd_status(args: argparse.Namespace) -> int:
    """``facesynth status``: live services and their latest stats."""
    from facesynth.runtime.codec import decode
    from schemas.messages import ServiceStats

    options = wiring.zenoh_options(args)
    rig = None if args.all_rigs else args.rig

    async def main() -> tuple[list[str], dict[str, ServiceStats]]:
        bus = await asyncio.to_thread(ZenohBus.open, options)
        try:
            subscription = bus.subscribe_queued(keys.stats_pattern(rig), 256)
            alive = await bus.alive(keys.health_pattern(rig), timeout=min(args.timeout, 2.0))
            stats: dict[str, ServiceStats] = {}
            deadline = time.monotonic() + args.timeout
            while (remaining := deadline - time.monotonic()) > 0:
                try:
                    sample = await asyncio.wait_for(subscription.receive(), remaining)
                except TimeoutError:
                    break
                try:
                    stats[sample.key] = decode(sample.payload, ServiceStats)
                except ValueError as exc:
                    log.warning("ignored stats on %s: %s", sample.key, exc)
            return alive, stats
        finally:
            await bus.close()

    alive, stats = run_async(main())
    print(format_status(alive, stats))
    return 0 if alive else 1


def format_status(alive: list[str], stats: dict[str, Any]) -> str:
    """A table of live services with their latest stats."""
    by_instance = {keys.parse_service_key(k): s for k, s in stats.items()}
    header = (
        f"{'rig':<12} {'service':<11} {'instance':<28} {'rate Hz':>8} {'p50 ms':>8} "
        f"{'p99 ms':>8} {'recv':>7} {'sent':>7} {'drop':>5} {'rej':>5} {'RSS MB':>7}"
    )
    lines = [header]
    for key in alive:
        parsed = keys.parse_service_key(key)
        if parsed is None:
            continue
        s = by_instance.get(parsed)
        if s is None:
            lines.append(f"{parsed[0]:<12} {parsed[1]:<11} {parsed[2]:<28} {'(no stats yet)':>8}")
            continue
        p50 = f"{s.latency_p50_ms:.2f}" if s.latency_p50_ms is not None else "-"
        p99 = f"{s.latency_p99_ms:.2f}" if s.latency_p99_ms is not None else "-"
        lines.append(
            f"{parsed[0]:<12} {parsed[1]:<11} {parsed[2]:<28} {s.rate_hz:>8.1f} {p50:>8} {p99:>8} "
            f"{s.received:>7} {s.published:>7} {s.dropped:>5} {s.rejected:>5} {s.rss_mb:>7.1f}"
        )
    if len(lines) == 1:
        lines.append("(no live services)")
    return "\n".join(lines)


def cmd_profile(args: argparse.Namespace) -> int:
    """``facesynth profile list|check|show``."""
    import sys

    from facesynth.runtime.profiles import (
        ProfileError,
        available_profiles,
        describe_source,
        load_profile,
    )

    if args.action == "list":
        for name in available_profiles():
            print(name)
        return 0
    if not args.name:
        raise OptionError(f"profile {args.action} needs a profile name or path")
    if args.action == "check":
        try:
            profile = load_profile(args.name)
        except ProfileError as exc:  # every problem, one line each, as the CLI's errors
            for problem in exc.problems:
                print(f"facesynth profile: error: {problem}", file=sys.stderr)
            return 2
        print(f"{args.name}: ok ({len(profile.servos)} servos)")
        return 0
    profile = load_profile(args.name)
    for spec in profile.servos:
        print(
            f"{spec.channel:>3} {spec.name:<20} {spec.min_us:>7g} {spec.neutral_us:>7g} "
            f"{spec.max_us:>7g} "
            f"{'reversed' if spec.reversed else '':<8} {describe_source(spec)}"
        )
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    """``facesynth bench chain|tracker|smoothing|fidelity``."""
    if args.what == "fidelity":
        return _bench_fidelity(args)
    if args.what == "smoothing":
        from facesynth.app.bench.smoothing import bench_smoothing, format_smoothing

        print(format_smoothing(bench_smoothing(args.profile, track=args.track)))
        return 0
    if args.what == "recording":
        from facesynth.app.bench.recording import bench_recording, format_recording_bench

        print(format_recording_bench(bench_recording(minutes=args.minutes, fps=args.fps)))
        return 0
    if args.what == "face":
        from facesynth.app.bench.face import bench_face, format_face

        print(format_face(bench_face(seconds=args.seconds or 3.0, rate=args.rate)))
        return 0
    if args.what == "chain":
        return _bench_chain(args)
    if args.what == "fanout":
        return _bench_fanout(args)
    from facesynth.app.bench.tracker import bench_tracker, format_bench
    from facesynth.app.data import sample_video
    from services.points.tracker.landmarkers import model_names

    backends = tuple(b for b in args.backends.split(",") if b)
    models = tuple(m for m in (args.models or "fast,full").split(",") if m)
    unknown = [m for m in models if m not in model_names()]
    if unknown or not models:
        choices = ", ".join(model_names())
        raise OptionError(f"--models: unknown {unknown}; choose from {choices}")
    result = bench_tracker(
        args.video or str(sample_video()),
        backends=backends,
        frames=args.frames,
        models=models,
        repeat=args.repeat,
        mediapipe_python=args.mediapipe_python,
        mediapipe_task=args.mediapipe_task,
    )
    print(format_bench(result))
    return 0


def _choices(value: str, flag: str, allowed: tuple[str, ...]) -> list[str]:
    """A comma-separated list of choices (``jpeg,raw``), each checked."""
    chosen = [item.strip() for item in value.split(",") if item.strip()]
    unknown = [item for item in chosen if item not in allowed]
    if unknown or not chosen:
        raise OptionError(
            f"{flag}: unknown {', '.join(unknown) or 'empty list'}; "
            f"choose from {', '.join(allowed)}"
        )
    return chosen


def _bench_chain(args: argparse.Namespace) -> int:
    """``facesynth bench chain``: the variants asked for, side by side, ``--runs`` times."""
    from facesynth.app.bench.chain import SCHEDULES, bench_chain, variants
    from facesynth.app.bench.chain_report import format_chain_bench
    from services.points.tracker.landmarkers import model_names

    if args.runs < 1:
        raise OptionError("--runs must be at least 1")
    threads = [int(t) for t in _choices(args.threads, "--threads", tuple(map(str, range(1, 9))))]
    chosen = variants(
        encodings=_choices(args.encoding, "--encoding", ("jpeg", "raw")),
        models=_choices(args.models or "full", "--models", tuple(model_names())),
        threads=threads,
        modes=_choices(args.mode, "--mode", ("client", "peer")),
        scheds=_choices(args.sched, "--sched", SCHEDULES),
        baseline=_baseline(args.baseline),
    )
    figures = bench_chain(
        chosen,
        runs=args.runs,
        video=args.video,
        seconds=args.seconds or 15.0,
        fps=args.fps,
        openface_csv=args.openface_csv,
        hops=args.hops,
    )
    print(format_chain_bench(figures))
    return 0


def _bench_fanout(args: argparse.Namespace) -> int:
    """``facesynth bench fanout``: one performer, N robots, in each layout, side by side."""
    from facesynth.app.bench.chain import REALTIME_PRIORITY, SCHEDULES
    from facesynth.app.bench.fanout import bench_fanout, check_layout
    from facesynth.app.bench.fanout_report import format_fanout
    from services.points.tracker.landmarkers import model_names

    try:
        counts = [int(n) for n in args.robots.split(",") if n.strip()]
    except ValueError:
        raise OptionError(f"--robots: not a list of numbers: {args.robots!r}") from None
    if not counts or min(counts) < 1:
        raise OptionError("--robots: give one or more counts of at least 1, e.g. 1,4,8,16,32")
    if args.runs < 1:
        raise OptionError("--runs must be at least 1")
    (model,) = _single(args.models or "full", "--models", tuple(model_names()))
    (encoding,) = _single(args.encoding, "--encoding", ("jpeg", "raw"))
    (mode,) = _single(args.mode, "--mode", ("client", "peer"))
    (sched,) = _single(args.sched, "--sched", SCHEDULES)
    layouts = [item.strip() for item in args.layout.split(",") if item.strip()]
    try:
        layouts = [check_layout(layout) for layout in layouts]
    except ValueError as exc:
        raise OptionError(f"--layout: {exc}") from None
    if not layouts:
        raise OptionError("--layout: give one or more layouts")
    figures = bench_fanout(
        counts,
        layouts,
        runs=args.runs,
        video=args.video,
        seconds=args.seconds or 10.0,
        fps=args.fps,
        model=model,
        encoding=encoding,
        mode=mode,
        realtime=REALTIME_PRIORITY if sched == "realtime" else None,
    )
    print(format_fanout(figures, model=model, encoding=encoding, mode=mode, sched=sched))
    return 0


def _baseline(path: str | None) -> str:
    """``--baseline DIR``: a source tree holding another facesynth package, or ``""``."""
    if not path:
        return ""
    if not (Path(path) / "facesynth" / "__main__.py").is_file():
        raise OptionError(f"--baseline {path}: no facesynth source tree there (facesynth/ missing)")
    return path


def _single(value: str, flag: str, allowed: tuple[str, ...]) -> list[str]:
    """One choice (``fanout`` compares layouts and robot counts, not these)."""
    chosen = _choices(value, flag, allowed)
    if len(chosen) != 1:
        raise OptionError(f"{flag}: bench fanout takes one value, not {value!r}")
    return chosen


def _bench_fidelity(args: argparse.Namespace) -> int:
    """``facesynth bench fidelity``: synthetic expressions through every profile and model."""
    from facesynth.app.bench.fidelity import PROFILES, bench_fidelity, format_fidelity
    from facesynth.app.data import sample_video
    from facesynth.runtime.profiles import resolve_profile
    from services.points.tracker.landmarkers import model_names

    models = tuple(m for m in (args.models or "fast,full").split(",") if m)
    unknown = [m for m in models if m not in model_names()]
    if unknown or not models:
        choices = ", ".join(model_names())
        raise OptionError(f"--models: unknown {unknown}; choose from {choices}")
    profiles = tuple(p for p in (args.profiles or ",".join(PROFILES)).split(",") if p)
    for profile in profiles:
        resolve_profile(profile)  # a clear error for an unknown name before any tracking
    rows = bench_fidelity(args.video or str(sample_video()), models, profiles)
    print(format_fidelity(rows))
    return 0


def cmd_calibrate(args: argparse.Namespace) -> int:
    """``facesynth calibrate NAME``."""
    from facesynth.app.calibrate_cli import run_calibration

    run_calibration(args)
    return 0


def cmd_track(args: argparse.Namespace) -> int:
    """``facesynth track VIDEO --out FILE``."""
    from services.points.tracker.landmarkers import model_config
    from services.points.tracker.offline import track_video

    options = {"blendshapes": args.blendshapes} if args.model == "full" else {}
    model = model_config(args.model, **options)
    summary = track_video(args.video, args.out, backend=args.inference, model=model)
    print(json.dumps(summary))
    return 0
