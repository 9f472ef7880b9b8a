"""``facesynth sensor|points|features|translator|control``: one node of a graph as its own
service (process), joining the rig's router."""

from __future__ import annotations

import argparse
import logging
from collections.abc import Callable

from facesynth.app import wiring
from facesynth.app.chain import (
    run_single,
)
from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import graph_arguments, zenoh_arguments
from facesynth.app.control_tools import TEST_OPTIONS, add_tool_arguments, cmd_control_tool
from facesynth.app.graph import Graph, check_node, load_graph, select_node
from facesynth.app.nodes import SensorNode, stage_of
from facesynth.app.plugin_help import describe_plugins
from facesynth.app.profile_choice import settle
from facesynth.app.stage_args import add_stage_arguments, apply_arguments
from facesynth.app.stages.registry import STAGES
from facesynth.app.tuning import tune_process
from facesynth.app.wiring import OptionError, build_node, replay_frames_of
from facesynth.runtime.service import default_instance, run_async
from facesynth.services.control.drivers.registry import DRIVERS

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
        name, node = stage, STAGES.get(stage).node()
        graph = Graph(nodes={name: node})  # type: ignore[dict-item]  # any registered stage
    node, config = apply_arguments(name, node, args)
    check_node(name, node, args.graph or "command line")
    graph.nodes[name] = node
    setup = settle(graph, {name: config} if config is not None else None, plugins=False)
    tune_process([node])
    replay_frames = None
    if isinstance(node, SensorNode) and args.graph:
        if not node.wait_for:  # started from a graph: wait for the graph's other stages
            others = {stage_of(n) for n in graph.nodes.values() if STAGES.of(n).consumes}
            node.wait_for = sorted(others)
        replay_frames = replay_frames_of(graph)
    parts = build_node(
        name, node, graph, config, replay_frames=replay_frames, standalone=True, setup=setup
    )
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


def _arguments(stage: str) -> Callable[[argparse.ArgumentParser], None]:
    def declare(p: argparse.ArgumentParser) -> None:
        graph_arguments(p)
        add_stage_arguments(p, [stage])
        zenoh_arguments(p)
        if stage == "control":
            p.add_argument(
                "--list-drivers",
                action="store_true",
                help="list the servo drivers and their options, then exit",
            )
            add_tool_arguments(p)

    return declare


def stage_commands() -> tuple[Command, ...]:
    """One command per stage registered when the parser is built, its help the descriptor's: a
    stage registered after import (a plugin's, a test file's) gets its command too."""
    return tuple(
        Command(stage.name, stage.help, cmd_stage, _arguments(stage.name), {"stage": stage.name})
        for stage in STAGES
    )


#: Read by :mod:`facesynth.app.command_registry` each time the parser is built.
COMMANDS = stage_commands
