"""``facesynth compose GRAPH``: the docker-compose file that runs a graph's nodes."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from facesynth.app.command_registry import Command
from facesynth.app.compose import compose_file, override_file, secure_file
from facesynth.app.graph import load_graph
from facesynth.app.wiring import OptionError
from facesynth.runtime.atomic import write_atomic

log = logging.getLogger("facesynth")


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


HELP = "write the docker-compose file that runs each node of a graph in a container"


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("graph", metavar="GRAPH", help="graph file")
    p.add_argument("--out", metavar="FILE", help="write here (default: print it)")
    p.add_argument(
        "--graph-path",
        help="where the graph is seen in the containers (default: its place under deploy/, "
        "mounted at /etc/facesynth, e.g. /etc/facesynth/graph.toml)",
    )
    p.add_argument(
        "--secure",
        action="store_true",
        help="write the override that secures every link (mutual TLS, access control)",
    )
    p.add_argument(
        "--override",
        action="store_true",
        help="write an override that runs this graph's nodes in place of the same-named "
        "services (e.g. a control node with another driver)",
    )


COMMANDS = (Command("compose", HELP, cmd_compose, _arguments),)
