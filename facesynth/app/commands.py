"""Implementations of the ``facesynth`` sub-commands (the parser lives in ``cli``)."""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import time
from pathlib import Path
from typing import Any

from facesynth.app import wiring
from facesynth.app.chain import (
    ChainResult,
    build_chain,
    freeze_startup_objects,
    open_embedded,
    run_chain,
    run_single,
)
from facesynth.app.compose import compose_file, override_file, secure_file
from facesynth.app.control_tools import TEST_OPTIONS, cmd_control_tool
from facesynth.app.graph import Graph, load_graph, select_node
from facesynth.app.nodes import NODE_TYPES, SensorNode, stage_of
from facesynth.app.plugin_help import describe_plugins
from facesynth.app.recording.attach import attached
from facesynth.app.stage_args import apply_arguments
from facesynth.app.wiring import OptionError, build_node, replay_frames_of
from facesynth.runtime import keys
from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.bus.zenoh_bus import ZenohBus, endpoints, open_session, router_locators
from facesynth.runtime.outputs import check_output
from facesynth.runtime.service import default_instance, run_async, until_signalled
from services.control.drivers.registry import DRIVERS

log = logging.getLogger("facesynth")


def cmd_stage(args: argparse.Namespace) -> int:
    """``facesynth sensor|points|features|translator|control``: one node as its own service."""
    stage: str = args.stage
    if getattr(args, "list_drivers", False):
        print(describe_plugins(DRIVERS))
        return 0
    if stage == "control" and (
        args.action or any(getattr(args, name) not in (None, False) for name in TEST_OPTIONS)
    ):
        return cmd_control_tool(args)
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
    graph.nodes[name] = node
    replay_frames = None
    if isinstance(node, SensorNode) and args.graph:
        if not node.wait_for:  # started from a graph: wait for the graph's other stages
            others = {stage_of(n) for n in graph.nodes.values() if stage_of(n) != "sensor"}
            node.wait_for = sorted(others)
        replay_frames = replay_frames_of(graph)
    parts = build_node(name, node, graph, config, replay_frames=replay_frames, standalone=True)
    options = wiring.zenoh_options(args, wait_for_router=True)
    rig = args.rig or graph.rig
    instance = None if name == stage else f"{default_instance()}-{name}"
    run_async(
        run_single(
            options, rig, stage, parts.body, instance=instance, stats_interval=args.stats_interval
        )
    )
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    """``facesynth run [GRAPH]``: every node of a graph in one process."""
    graph = load_graph(args.graph, plugins=False)
    configs = {}
    for name, node in list(graph.nodes.items()):
        graph.nodes[name], configs[name] = apply_arguments(name, node, args)
    rig = args.rig or graph.rig
    check_run_outputs(args)
    parts = build_chain(graph, configs)
    listen = endpoints(args.listen) or ["tcp/127.0.0.1:7447"]
    options = wiring.zenoh_options(args, default_mode="router")
    options.connect = endpoints(args.connect)

    async def main() -> ChainResult:
        session, locators = await asyncio.to_thread(open_embedded, listen, options)
        bus = ZenohBus(session, mode="router")
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


def check_run_outputs(args: argparse.Namespace) -> None:
    """``run --render`` and ``--record`` paths, checked before the chain starts."""
    if args.render:
        from facesynth.app.render.video import check_render_out

        check_render_out(args.render)
    record = getattr(args, "record", None)
    if record:
        if Path(record).exists():
            raise OptionError(f"--record {record} exists (a session file is never overwritten)")
        check_output(record, "session file")


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
    graph = load_graph(args.graph)
    if args.secure and args.override:
        raise OptionError("choose one of --secure and --override")
    if args.secure:
        text = secure_file(graph, args.graph)
    elif args.override:
        text = override_file(graph, args.graph, graph_path=args.graph_path)
    else:
        text = compose_file(graph, args.graph, graph_path=args.graph_path)
    if args.out:
        write_atomic(Path(args.out), text.encode(), mode=0o644)
    else:
        print(text, end="")
    return 0


def cmd_certs(args: argparse.Namespace) -> int:
    """``facesynth certs RIG``: a rig's CA, certificates and secured Zenoh configs."""
    from facesynth.app.certs import CertRequest, describe, make_certs
    from facesynth.app.secure import CertPaths, rig_configs

    out = Path(args.out)
    connect = endpoints(args.connect) or ["tls/localhost:7447"]
    listen = endpoints(args.listen) or ["tls/0.0.0.0:7447"]
    if args.configs_only:
        paths = CertPaths(args.cert_dir or str(out.resolve()))
        written = [
            write_atomic(out / name, text, mode=0o644)
            for name, text in rig_configs(args.rig, paths, connect=connect, listen=listen).items()
        ]
    else:
        request = CertRequest(
            rig=args.rig,
            out=out,
            router_names=args.router_host,
            days=args.days,
            force=args.force,
            connect=connect,
            listen=listen,
            cert_dir=args.cert_dir,
        )
        if args.identity:
            request.identities = args.identity
        written = make_certs(request)
    print(describe(written, out))
    return 0


def cmd_router(args: argparse.Namespace) -> int:
    """``facesynth router``: a Zenoh router in Python."""
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
                    async with asyncio.timeout(remaining):
                        sample = await subscription.receive()
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
        f"{'p99 ms':>8} {'recv':>7} {'sent':>7} {'drop':>5} {'rej':>5} {'router':<21} "
        f"{'RSS MB':>7}  state"
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
            f"{s.received:>7} {s.published:>7} {s.dropped:>5} {s.rejected:>5} "
            f"{describe_link(s):<21} {s.rss_mb:>7.1f}" + (f"  {s.note}" if s.note else "")
        )
    if len(lines) == 1:
        lines.append("(no live services)")
    return "\n".join(lines)


def cmd_health(args: argparse.Namespace) -> int:
    """``facesynth health``: 0 when this host's service is live on the rig's router, else 1.

    Unhealthy is exit status 1 whatever the reason (no router, no token), as container health
    checks expect; the reason is printed.
    """
    from facesynth.runtime.bus.zenoh_bus import ZenohConfigError
    from facesynth.runtime.service import host_id

    options = wiring.zenoh_options(args)
    # Give up on an absent router within the timeout, whatever the config file says.
    options.overrides.update(
        {"connect/timeout_ms": round(args.timeout * 1000), "connect/exit_on_failure": True}
    )
    host = args.host or host_id()

    async def main() -> tuple[bool, str]:
        try:
            bus = await asyncio.to_thread(ZenohBus.open, options)
        except ZenohConfigError as exc:
            return False, str(exc)
        try:
            if args.router:
                routers = [str(z) for z in bus.session.info.routers_zid()]
                if routers:
                    return True, f"router {routers[0][:8]} accepts sessions"
                return False, "no router answered"
            alive = await bus.alive(keys.health_pattern(args.rig), timeout=args.timeout)
            mine = [
                key
                for key in alive
                if (parsed := keys.parse_service_key(key)) and parsed[2].startswith(f"{host}-")
            ]
            if mine:
                return True, " ".join(mine)
            return False, f"no live service of host {host!r} on the router"
        finally:
            await bus.close()

    healthy, reason = run_async(main())
    print(f"{'healthy' if healthy else 'unhealthy'}: {reason}")
    return 0 if healthy else 1


def describe_link(stats: Any) -> str:
    """A service's link to its router, from its stats: up, down, and how often it was lost."""
    connected = getattr(stats, "router_connected", None)
    if connected is None:
        return "-"
    state = "up" if connected else "down"
    if stats.router_losses:  # how often it was lost, and the time spent without it
        state += f", lost {stats.router_losses}x ({stats.router_offline_s:.1f} s)"
    return state


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
    """``facesynth bench chain|tracker|smoothing|recording|face|fidelity|drivers``."""
    if args.what == "fidelity":
        return _bench_fidelity(args)
    if args.what == "drivers":
        from facesynth.app.bench.drivers import bench_drivers, format_drivers

        print(format_drivers(*bench_drivers(args.profile)))
        return 0
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
        from facesynth.app.bench.chain import bench_chain, format_chain_bench

        print(
            format_chain_bench(
                bench_chain(
                    video=args.video,
                    seconds=args.seconds or 15.0,
                    fps=args.fps,
                    openface_csv=args.openface_csv,
                    encoding=args.encoding,
                    threads=args.threads,
                    mode=args.mode,
                )
            )
        )
        return 0
    from facesynth.app.bench.tracker import bench_tracker, format_bench
    from facesynth.app.data import sample_video
    from services.points.tracker.landmarkers import model_names

    backends = tuple(b for b in args.backends.split(",") if b)
    models = tuple(m for m in args.models.split(",") if m)
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


def _bench_fidelity(args: argparse.Namespace) -> int:
    """``facesynth bench fidelity``: synthetic expressions through every profile and model."""
    from facesynth.app.bench.fidelity import PROFILES, bench_fidelity, format_fidelity
    from facesynth.app.data import sample_video
    from facesynth.runtime.profiles import resolve_profile
    from services.points.tracker.landmarkers import model_names

    models = tuple(m for m in args.models.split(",") if m)
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

    check_output(args.out, "track file")
    options = {"blendshapes": args.blendshapes} if args.model == "full" else {}
    model = model_config(args.model, **options)
    summary = track_video(args.video, args.out, backend=args.inference, model=model)
    print(json.dumps(summary))
    return 0
