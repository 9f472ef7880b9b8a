"""``facesynth run [GRAPH]``: every node of a graph in one process, on a router embedded in it."""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path
from typing import Any

from facesynth.app import wiring
from facesynth.app.chain import (
    ChainResult,
    build_chain,
    build_nodes,
    freeze_startup_objects,
    serve_nodes,
)
from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import zenoh_arguments
from facesynth.app.engine.chain_run import run_embedded_chain
from facesynth.app.engine.router import RUN_LISTEN, joined_bus
from facesynth.app.graph import Graph, check_node, graph_help, load_graph
from facesynth.app.profile_choice import settle
from facesynth.app.recording.attach import add_attach_arguments, attached
from facesynth.app.stage_args import add_stage_arguments, apply_arguments
from facesynth.app.stages.registry import STAGES
from facesynth.app.stages.setup import Setup
from facesynth.app.tuning import tune_process
from facesynth.app.wiring import OptionError
from facesynth.runtime.outputs import check_output
from facesynth.runtime.service import run_async
from facesynth.services.control.drivers.record import RecordConfig, earlier_sessions, record_summary

log = logging.getLogger("facesynth")


def run_graph(args: argparse.Namespace) -> tuple[Graph, dict[str, Any], Setup]:
    """The graph ``facesynth run`` runs for ``args``: its file (or the demo) with the command
    line's options applied to each node, each node's plugin configs, and the settled setup."""
    graph = load_graph(args.graph, plugins=False)
    configs = {}
    for name, node in list(graph.nodes.items()):
        graph.nodes[name], configs[name] = apply_arguments(name, node, args)
        check_node(name, graph.nodes[name], args.graph or "command line")
    return graph, configs, settle(graph, configs)


def cmd_run(args: argparse.Namespace) -> int:
    """``facesynth run [GRAPH]``: every node of a graph in one process."""
    graph, configs, setup = run_graph(args)
    rig = args.rig or graph.rig
    check_run_outputs(args, graph, configs)
    tune_process(graph.nodes.values())
    if not graph.sources():
        return _serve_graph(args, graph, configs, rig, setup)
    records = {
        c.out: earlier_sessions(c.out) for c in configs.values() if isinstance(c, RecordConfig)
    }
    parts = build_chain(graph, configs, setup)
    result = run_embedded_chain(args, rig, parts, attached)
    outs = [
        getattr(configs[name], "out", configs[name].__struct_config__.tag)
        for name in graph.of_stages(STAGES.producing("servo_state"))
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
            graph,
            configs,
            args.render,
            frames=result.frames,
            interrupted=result.interrupted,
            setup=setup,
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


def _serve_graph(
    args: argparse.Namespace, graph: Graph, configs: dict[str, Any], rig: str, setup: Setup
) -> int:
    """``facesynth run`` of a graph without a sensor: its nodes (say, a robot host's translators
    and control interfaces) in one process, fed from the bus, until a signal arrives.

    As a router by default (listening where ``run`` does); ``--mode client|peer`` joins the
    router or peers given by ``--connect`` instead, like a stage command; exits 0 when
    signalled, as a stage command does."""
    parts = build_nodes(graph, configs, setup)
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


HELP = (
    "run a chain graph (default: the demo, S → P → F → T → C) in one process on an "
    "embedded Zenoh router"
)


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("graph", nargs="?", metavar="GRAPH", help=graph_help())
    add_stage_arguments(p, STAGES.names())
    add_attach_arguments(p)
    zenoh_arguments(p)
    p.add_argument(
        "--drain-timeout",
        type=float,
        default=3.0,
        help="seconds to wait for the last command after the input ends",
    )
    p.add_argument(
        "--render",
        metavar="OUT.mp4",
        help="when the input ends, also write the side-by-side video of it (performer with "
        "landmarks | virtual face | servo bars of the translator's profile); after Ctrl-C, of "
        "the frames played so far (Ctrl-C again skips it); see render",
    )


COMMANDS = (Command("run", HELP, cmd_run, _arguments),)
