"""``facesynth render [GRAPH] --out OUT.mp4``: the side-by-side video of a graph's input."""

from __future__ import annotations

import argparse
import json
import logging

from facesynth.app.command_registry import Command
from facesynth.app.graph import graph_help, load_graph
from facesynth.app.nodes import stage_of
from facesynth.app.profile_choice import settle_profiles
from facesynth.app.stage_args import add_stage_arguments, apply_arguments

log = logging.getLogger("facesynth")


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
        closed_loop=args.closed_loop,
    )
    print(json.dumps(summary))
    return 0


HELP = (
    "write the side-by-side video of a chain's input video: performer with landmarks | "
    "virtual face | servo bars, one output frame per input frame"
)


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("graph", nargs="?", metavar="GRAPH", help=graph_help())
    p.add_argument("--out", required=True, metavar="OUT.mp4", help="video file (.mp4, .avi, …)")
    p.add_argument(
        "--bars",
        metavar="PROFILE",
        help="servo bars of this profile (default: the translator's profile unless it is "
        "virtual; none: no bars)",
    )
    p.add_argument(
        "--same-size",
        action="store_true",
        help="scale each side-by-side frame into the input's own size (default: the "
        "performer keeps its size and the panels are added beside it)",
    )
    p.add_argument(
        "--robot-head",
        metavar="HEAD",
        help="show a simulated head (a bundled name such as simhead16, or a head file) "
        "driven by the translator's profile (--profile) instead of the virtual face: "
        "performer | robot's camera | bars of what it was sent",
    )
    p.add_argument(
        "--closed-loop",
        action="store_true",
        help="with --robot-head and a learned --profile: performer | the head with T's loop "
        "closed through its own camera | the same head in open loop (no bars)",
    )
    add_stage_arguments(p, ["sensor", "points", "features", "translator"])
    p.add_argument("--log-level", default="WARNING", choices=("DEBUG", "INFO", "WARNING", "ERROR"))


COMMANDS = (Command("render", HELP, cmd_render, _arguments),)
