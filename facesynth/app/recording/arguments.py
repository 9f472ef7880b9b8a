"""What the ``record``, ``replay``, ``inspect`` and ``convert`` sub-commands take (their
handlers are :mod:`facesynth.app.recording.cli`)."""

from __future__ import annotations

import argparse

from facesynth.app.common_arguments import zenoh_arguments
from facesynth.app.recording import RECORDABLE, REPLAYABLE


def record_arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth record``."""
    p.add_argument(
        "--out",
        metavar="SESSION.mcap",
        help="the recording; with --check: where a recovered copy goes",
    )
    p.add_argument(
        "--check", metavar="FILE", help="say what FILE holds; recover what a torn FILE still has"
    )
    p.add_argument(
        "--keys",
        metavar="LIST",
        help=f"comma-separated, from {','.join(RECORDABLE)} (default: all); servo_commands "
        "and servo_state take every robot's too (…/servo_commands/ROBOT)",
    )
    p.add_argument(
        "--frame-every",
        type=int,
        default=1,
        metavar="N",
        help="record every Nth frame; 0 = no frames (default 1)",
    )
    p.add_argument(
        "--duration", type=float, metavar="S", help="stop after S seconds (default: until Ctrl-C)"
    )
    p.add_argument(
        "--chunk-mb", type=float, default=1.0, metavar="MB", help="chunk size (default 1)"
    )
    p.add_argument(
        "--chunk-seconds",
        type=float,
        default=1.0,
        metavar="S",
        help="cut a chunk at least every S seconds: a kill loses at most that (default 1)",
    )
    p.add_argument(
        "--compression",
        choices=("zstd", "lz4", "none"),
        default="zstd",
        help="chunk compression (default zstd)",
    )
    p.add_argument(
        "--no-fsync",
        action="store_true",
        help="do not fsync each chunk "
        "(a kill still loses only the last chunk; a power cut may lose more)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing file")
    zenoh_arguments(p)


def replay_arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth replay``."""
    p.add_argument("session", metavar="SESSION.mcap")
    p.add_argument(
        "--from",
        dest="from_stage",
        choices=REPLAYABLE,
        help="stage to replay (default: the earliest recorded); servo_commands: every "
        "robot's too, each on its robot's key",
    )
    pace = p.add_mutually_exclusive_group()
    pace.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="X",
        help="timing factor: 2 = twice as fast (default 1)",
    )
    pace.add_argument(
        "--fast", action="store_true", help="as fast as the chain takes it, nothing lost"
    )
    p.add_argument(
        "--window",
        type=int,
        default=2,
        help="--fast: messages in flight ahead of the last servo command (default 2)",
    )
    p.add_argument(
        "--restamp",
        action="store_true",
        help="set capture times to the replay's clock (latencies read as live)",
    )
    p.add_argument(
        "--wait-for",
        action="append",
        metavar="SERVICES",
        help="wait until these services are alive, e.g. features,translator,control",
    )
    p.add_argument(
        "--wait-timeout",
        type=float,
        default=30.0,
        help="seconds to wait for --wait-for (default 30)",
    )
    graph = p.add_argument_group("through a graph, in this process")
    graph.add_argument(
        "--graph",
        nargs="?",
        const="",
        metavar="FILE",
        help="run the graph's nodes after the replayed stage here, on an embedded router "
        "(no FILE: the demo graph); their flags below override the file",
    )
    graph.add_argument(
        "--drain-timeout",
        type=float,
        default=3.0,
        help="--graph: seconds to wait for the last command after the replay ends",
    )
    from facesynth.app.recording.attach import add_attach_arguments
    from facesynth.app.stage_args import add_stage_arguments
    from facesynth.app.stages.registry import STAGES

    downstream = [name for name in STAGES.names() if name not in STAGES.sources()]
    add_stage_arguments(p, downstream)  # the stages a replay can feed, in chain order
    add_attach_arguments(p)
    zenoh_arguments(p)


def inspect_arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth inspect``."""
    p.add_argument(
        "--foxglove",
        default="127.0.0.1:8765",
        metavar="HOST:PORT",
        help="where to listen (default 127.0.0.1:8765; port 0: any free port)",
    )
    p.add_argument(
        "--frame-every", type=int, default=1, metavar="N", help="show every Nth frame (default 1)"
    )
    zenoh_arguments(p)


def convert_arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth convert``."""
    p.add_argument("input", help="an OpenFace .csv, a facesynth track .jsonl, or a recording .mcap")
    p.add_argument(
        "output",
        help=".mcap (from landmarks); .jsonl (record driver lines) or .csv (from a recording)",
    )
    p.add_argument(
        "--stage",
        choices=("servo_state", "servo_commands", "features"),
        help="what to export (default servo_state, else servo_commands)",
    )
    p.add_argument(
        "--robot",
        metavar="NAME",
        help="a multi-robot rig's recording: export this robot's commands "
        "(…/servo_state/NAME; needed when several robots are recorded)",
    )
    p.add_argument(
        "--rig", default="default", help="landmarks: rig of the recorded keys (default 'default')"
    )
    p.add_argument("--fps", type=float, default=30.0, help="landmarks: frame rate (default 30)")
    p.add_argument(
        "--size", default="640x480", help="landmarks: image size WIDTHxHEIGHT (default 640x480)"
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing .mcap output")
    p.add_argument(
        "--to",
        choices=("rosbag2",),
        help="rosbag2: a recording to a rosbag2 folder OUTPUT/ that ROS 2 tools play "
        "(JointState, CompressedImage, Float32MultiArray; MCAP, CDR)",
    )
    p.add_argument(
        "--profile",
        help="--to rosbag2: the profile whose angle maps give the radians (default: the one "
        "the commands name)",
    )
