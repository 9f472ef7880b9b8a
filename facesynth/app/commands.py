"""Implementations of the ``facesynth`` sub-commands (the parser lives in ``cli``)."""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from facesynth.app import wiring
from facesynth.app.chain import (
    ChainResult,
    build_chain,
    build_nodes,
    freeze_startup_objects,
    run_chain,
    run_single,
    serve_nodes,
)
from facesynth.app.compose import compose_file, override_file, secure_file
from facesynth.app.control_tools import TEST_OPTIONS, cmd_control_tool
from facesynth.app.engine.router import RUN_LISTEN, embedded_bus, joined_bus
from facesynth.app.graph import Graph, check_node, load_graph, select_node
from facesynth.app.nodes import NODE_TYPES, SensorNode, stage_of
from facesynth.app.plugin_help import describe_plugins
from facesynth.app.profile_choice import settle_profiles
from facesynth.app.recording.attach import attached
from facesynth.app.stage_args import apply_arguments
from facesynth.app.tuning import Scheduling, apply_scheduling, combined, keep_buffers
from facesynth.app.wiring import OptionError, build_node, replay_frames_of
from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.bus.zenoh_bus import endpoints, open_session, router_locators
from facesynth.runtime.outputs import check_output
from facesynth.runtime.profiles.learned import Learned, command_range
from facesynth.runtime.service import default_instance, run_async, until_signalled
from services.control.drivers.record import RecordConfig, earlier_sessions, record_summary
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
    check_node(name, node, args.graph or "command line")
    graph.nodes[name] = node
    settle_profiles(graph, {name: config})
    tune_process([node])
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
    settle_profiles(graph, configs)
    rig = args.rig or graph.rig
    check_run_outputs(args, graph, configs)
    tune_process(graph.nodes.values())
    if not graph.of_stage("sensor"):
        return _serve_graph(args, graph, configs, rig)
    records = {
        c.out: earlier_sessions(c.out) for c in configs.values() if isinstance(c, RecordConfig)
    }
    parts = build_chain(graph, configs)
    listen = endpoints(args.listen) or [RUN_LISTEN]
    options = wiring.zenoh_options(args, default_mode="router")
    options.connect = endpoints(args.connect)

    async def main() -> ChainResult:
        async with embedded_bus(listen, options, rig=rig, fallback=not args.listen) as (bus, _):
            freeze_startup_objects()
            async with attached(bus, rig, args):
                return await run_chain(
                    bus,
                    rig,
                    parts,
                    drain_timeout=args.drain_timeout,
                    stats_interval=args.stats_interval,
                )

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
    if records:  # each record file: created, or appended to (it is never truncated)
        entries = [record_summary(out, earlier) for out, earlier in records.items()]
        summary["record"] = entries[0] if len(entries) == 1 else entries
    if args.render:  # after Ctrl-C too: the frames played so far, or one line why not
        from facesynth.app.render import render_run

        summary["render"] = render_run(
            graph, configs, args.render, frames=result.frames, interrupted=result.interrupted
        )
    print(json.dumps(summary))
    return 130 if result.interrupted else 0


def check_run_outputs(args: argparse.Namespace, graph: Graph, configs: dict[str, Any]) -> None:
    """``run --render`` (path, graph input) and ``--record``, checked before the chain starts."""
    if args.render:
        from facesynth.app.render import video_input
        from facesynth.app.render.video import check_render_out

        check_render_out(args.render)
        video_input(graph, configs)
    record = getattr(args, "record", None)
    if record:
        if Path(record).exists():
            raise OptionError(f"--record {record} exists (a session file is never overwritten)")
        check_output(record, "session file")


def _serve_graph(args: argparse.Namespace, graph: Graph, configs: dict[str, Any], rig: str) -> int:
    """``facesynth run`` of a graph without a sensor: its nodes (say, a robot host's translators
    and control interfaces) in one process, fed from the bus, until a signal arrives.

    As a router by default (listening where ``run`` does); ``--mode client|peer`` joins the
    router or peers given by ``--connect`` instead, like a stage command; exits 0 when
    signalled, as a stage command does."""
    parts = build_nodes(graph, configs)
    options = wiring.zenoh_options(args, default_mode="router")
    if options.mode == "router" and not options.listen and options.config_file_path() is None:
        options.listen = [RUN_LISTEN]

    async def main() -> ChainResult:
        async with joined_bus(options) as bus:
            log.info("%d nodes of %s on rig %s", len(parts), args.graph, rig)
            freeze_startup_objects()
            return await serve_nodes(bus, rig, parts, stats_interval=args.stats_interval)

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

    graph = settle_profiles(load_graph(args.graph, plugins=False))
    configs = {}
    for name, node in list(graph.nodes.items()):
        if stage_of(node) == "control":
            del graph.nodes[name]
            continue
        graph.nodes[name], configs[name] = apply_arguments(name, node, args)
    summary = render_graph(
        graph,
        configs,
        args.out,
        bars=args.bars,
        same_size=args.same_size,
        robot_head=args.robot_head,
    )
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


def cmd_profile(args: argparse.Namespace) -> int:
    """``facesynth profile list|check|show`` (written, hardware-only and learned profiles)."""
    import sys

    from facesynth.runtime.profiles import (
        ProfileError,
        available_profiles,
        describe_learned,
        describe_source,
        has_source,
        load_profile,
    )

    if args.action == "list":
        for name in available_profiles(hardware=True):
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
        kind = ""
        if profile.learned is not None:
            kind = f"; {describe_learned(profile.learned)}"
        elif not any(has_source(spec) for spec in profile.servos):
            kind = "; hardware only: no sources, for facesynth learn and control"
        print(f"{args.name}: ok ({len(profile.servos)} servos{kind})")
        return 0
    profile = load_profile(args.name)
    learned = profile.learned
    if learned is not None:
        print(describe_learned(learned))
    print(
        f"{'ch':>3} {'servo':<20} {'min_us':>7} {'neutral':>7} {'max_us':>7} {'reversed':<8} source"
    )
    for spec in profile.servos:
        if learned is None:
            source = describe_source(spec)
        elif spec.name in learned.report.not_exercised:
            source = "learned: not exercised (never moved while babbling), kept at neutral"
        elif spec.name in learned.report.one_way:
            source = "learned: swept one way only, kept at neutral"
        elif spec.name in learned.dead:
            source = "learned: dead, kept at neutral"
        else:
            source = _learned_source(learned, spec.name)
        reversed_ = "reversed" if spec.reversed and learned is None else ""
        print(
            f"{spec.channel:>3} {spec.name:<20} {spec.min_us:>7g} {spec.neutral_us:>7g} "
            f"{spec.max_us:>7g} {reversed_:<8} {source}"
        )
    return 0


def _learned_source(learned: Learned, name: str) -> str:
    """A live learned servo's source column: its held-out errors, raw and effective (the
    goal's), and its responsive range when narrower than its travel."""
    error = learned.report.servo_error.get(name)
    effective = learned.report.effective_error.get(name)
    source = "learned" + (f": held-out error {error:.3f} of range" if error is not None else "")
    if effective is not None:
        source += f" (effective {effective:.3f})"
    low, high = command_range(learned)
    index = learned.outputs.index(name)
    if low[index] > -1.0 or high[index] < 1.0:
        source += f", responsive {low[index] + 0.0:+.2f} .. {high[index] + 0.0:+.2f}"
    return source


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
