"""``facesynth replay SESSION --graph [FILE]``: a recording through a graph, in one process.

The graph's nodes after the replayed stage run here on an embedded router, as ``facesynth
run`` runs them, and the replay takes the place of what comes before (the sensor and any
earlier stage): ``--from features`` with a graph whose translator names another profile replays
a performance onto another robot. The chain runner is ``run``'s own: it waits for the nodes,
plays the replay, and drains on ``…/servo_state``.
"""

from __future__ import annotations

import argparse
import logging
from typing import Any

from facesynth.app.engine.chain_run import run_embedded_chain
from facesynth.app.graph import load_graph
from facesynth.app.nodes import stage_of
from facesynth.app.profile_choice import settle
from facesynth.app.recording.attach import attached
from facesynth.app.recording.replay import Replayer
from facesynth.app.stage_args import apply_arguments
from facesynth.app.stages.registry import STAGES
from facesynth.app.wiring import OptionError, StageParts, build_node

log = logging.getLogger("facesynth")


def after(key: str) -> tuple[str, ...]:
    """The stages that run after the one producing ``key`` (a replayed stage), in chain order."""
    names = STAGES.names()
    producer = next(i for i, stage in enumerate(STAGES) if stage.produces == key)
    return names[producer + 1 :]


def graph_parts(replayer: Replayer, args: argparse.Namespace) -> tuple[list[StageParts], str, Any]:
    """The graph's nodes after the replayed stage, built with the command line's flags."""
    graph = load_graph(args.graph or None, plugins=False)
    wanted = after(replayer.stage)
    parts = []
    configs = {}
    for name, node in graph.nodes.items():
        if stage_of(node) in wanted:
            graph.nodes[name], configs[name] = apply_arguments(name, node, args)
    setup = settle(graph, configs, plugins=False)
    for name, node in graph.nodes.items():
        if stage_of(node) in wanted:
            parts.append(
                build_node(
                    name, node, graph, configs[name], fast=replayer.options.fast, setup=setup
                )
            )
    if not parts:
        raise OptionError(
            f"the graph has no {', '.join(wanted)} node to replay {replayer.stage} into"
        )
    return parts, args.rig or graph.rig, configs


def replay_through_graph(
    replayer: Replayer, args: argparse.Namespace
) -> tuple[Any, str, dict[str, Any]]:
    """Run the replay and the graph's later nodes.

    Returns the replay's outcome (``None`` when interrupted), the rig, and what the chain did.
    """
    parts, rig, configs = graph_parts(replayer, args)
    replay_part = StageParts("replay", "replay", replayer.serve, replayer)
    result = run_embedded_chain(args, rig, [replay_part, *parts], attached)
    outs = [out for config in configs.values() if (out := getattr(config, "out", None))]
    chain = {
        "commands": result.commands,
        "last_frame_executed": result.last_frame,
        "rejected": result.rejected,
        "dropped": result.dropped,
        "out": outs[0] if len(outs) == 1 else outs,
    }
    return (None if result.interrupted else replayer.published), rig, chain
