"""Arguments several commands share: the Zenoh group, a stage's graph node, the tracker model,
a performer calibration's steps."""

from __future__ import annotations

import argparse
import os

from facesynth.app import router_wait


def router_timeout(text: str) -> float:
    """``--router-timeout S``: seconds from 0 to a day."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not 0 <= value <= 86400:
        raise argparse.ArgumentTypeError(f"must be from 0 to 86400 seconds, not {text}")
    return value


def zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    """The Zenoh group every command with a session takes (``--rig``, ``--mode``, ``--connect``,
    ``--listen``, ``--zenoh-config``, the router wait of its kind, stats and logging)."""
    command = parser.prog.rsplit(" ", 1)[-1]
    kind = router_wait.kind_of(command)
    if kind is None:  # every command with a Zenoh session has its kind
        raise KeyError(command)
    group = parser.add_argument_group("Zenoh", router_wait.group_description(kind))
    group.add_argument(
        "--rig",
        default=os.environ.get("FACESYNTH_RIG"),
        help="rig name: keys are facesynth/<rig>/<stage> "
        "(default: $FACESYNTH_RIG, else the graph's, else 'default')",
    )
    group.add_argument(
        "--mode",
        choices=("peer", "client", "router"),
        help="Zenoh session mode (default: client of the router; run: router)",
    )
    group.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="endpoint to connect to, e.g. tcp/192.168.1.10:7447 "
        "(repeatable; default tcp/127.0.0.1:7447)",
    )
    group.add_argument(
        "--listen", action="append", metavar="ENDPOINT", help="endpoint to listen on (repeatable)"
    )
    group.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="Zenoh JSON5 config file (default: $ZENOH_CONFIG); options above override it",
    )
    if kind is not router_wait.RouterWait.OWN_ROUTER:
        group.add_argument(
            "--router-timeout",
            type=router_timeout,
            metavar="S",
            help=router_wait.timeout_help(kind, command),
        )
    group.add_argument(
        "--scouting",
        action="store_true",
        help="enable multicast scouting "
        "(off by default: sessions meet only the endpoints they are given)",
    )
    group.add_argument(
        "--stats-interval",
        type=float,
        default=1.0,
        metavar="S",
        help="seconds between stats messages (default 1)",
    )
    group.add_argument("--log-level", default="INFO", choices=("DEBUG", "INFO", "WARNING", "ERROR"))


def graph_arguments(parser: argparse.ArgumentParser) -> None:
    """A stage command's ``--graph FILE`` and ``--node NAME``."""
    group = parser.add_argument_group("graph")
    group.add_argument(
        "--graph",
        metavar="FILE",
        help="take this stage's options from a node of a graph file (flags override them)",
    )
    group.add_argument(
        "--node",
        metavar="NAME",
        help="the node to run (default: the graph's only node of this stage)",
    )


def model_arguments(parser: argparse.ArgumentParser) -> None:
    """``--model`` (choices and help from the tracker-model registry) and ``--no-blendshapes``."""
    from facesynth.services.points.tracker.landmarkers import TRACKER_MODELS

    summaries = "; ".join(f"{p.name}: {p.summary.rstrip('.')}" for p in TRACKER_MODELS)
    parser.add_argument(
        "--model",
        choices=TRACKER_MODELS.names(),
        default="full",
        help=f"tracker model (default full). {summaries}",
    )
    parser.add_argument(
        "--no-blendshapes",
        dest="blendshapes",
        action="store_false",
        help="with --model full: skip the blendshape model (about 0.4 ms a frame)",
    )


def calibration_step_arguments(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """A performer calibration's steps: ``--schedule`` (a video's), ``--steps`` and
    ``--seconds`` (a live camera's), for ``calibrate`` and ``console``."""
    parser.add_argument(
        "--schedule",
        metavar="STEP=START-END,…",
        help="for a video: when each step happens, in seconds, e.g. neutral=0-2,smile=5-7",
    )
    parser.add_argument(
        "--steps",
        default="neutral,raise_eyebrows,frown,look_left,look_right,look_up,look_down,"
        "raise_cheeks,open_mouth,smile",
        help="live camera: the steps to guide through, in order (default: the paper's ten)",
    )
    parser.add_argument(
        "--seconds", type=float, default=4.0, help="live camera: seconds per step (default 4)"
    )
