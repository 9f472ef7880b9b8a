"""The ``facesynth`` command: one sub-command per service, plus run, router, status, track, bench.

Every service command takes the standard Zenoh options (``--mode``, ``--connect``, ``--listen``,
``--zenoh-config`` or ``ZENOH_CONFIG``, ``--scouting``) and ``--rig``. Errors in options or files
are printed as one clear line and exit with status 2.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Callable, Sequence
from typing import Any

from facesynth import __version__
from facesynth.app.recording.attach import add_attach_arguments
from facesynth.app.stage_args import add_stage_arguments
from facesynth.runtime import keys
from services.control.drivers.base import DriverError
from services.points.tracker.runtimes import backend_choices

Handler = Callable[[argparse.Namespace], int]

#: The five stages' sub-commands.
STAGE_HELP = {
    "sensor": "S: publish frames from a video, camera or image folder on …/input",
    "points": "P: publish face landmarks on …/points (tracker, or a replayed recording)",
    "features": "F: publish pose-free features on …/features",
    "translator": "T: publish servo positions on …/servo_commands through a profile",
    "control": "C: drive servos (or record) from …/servo_commands",
}


def _zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("Zenoh")
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


def _graph_arguments(parser: argparse.ArgumentParser) -> None:
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


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser."""
    from facesynth.app import commands

    parser = argparse.ArgumentParser(
        prog="facesynth",
        description="Real-time facial expression synthesis for robot and virtual faces.",
    )
    parser.add_argument("--version", action="version", version=f"facesynth {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name: str, handler: Handler, help_text: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(handler=handler)
        return p

    p = add(
        "run",
        commands.cmd_run,
        "run a chain graph (default: the demo, S → P → F → T → C) in one process on an "
        "embedded Zenoh router",
    )
    p.add_argument("graph", nargs="?", metavar="GRAPH", help="graph file (default: the demo graph)")
    add_stage_arguments(p, keys.SERVICES)
    add_attach_arguments(p)
    _zenoh_arguments(p)
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
        "landmarks | virtual face | servo bars of the translator's profile); see render",
    )

    for stage, help_text in STAGE_HELP.items():
        p = add(stage, commands.cmd_stage, help_text)
        p.set_defaults(stage=stage)
        _graph_arguments(p)
        add_stage_arguments(p, [stage])
        _zenoh_arguments(p)
        if stage == "control":
            p.add_argument(
                "--list-drivers",
                action="store_true",
                help="list the servo drivers and their options, then exit",
            )

    p = add(
        "render",
        commands.cmd_render,
        "write the side-by-side video of a chain's input video: performer with landmarks | "
        "virtual face | servo bars, one output frame per input frame",
    )
    p.add_argument("graph", nargs="?", metavar="GRAPH", help="graph file (default: the demo graph)")
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
    add_stage_arguments(p, ["sensor", "points", "features", "translator"])
    p.add_argument("--log-level", default="WARNING", choices=("DEBUG", "INFO", "WARNING", "ERROR"))

    p = add(
        "compose",
        commands.cmd_compose,
        "write the docker-compose file that runs each node of a graph in a container",
    )
    p.add_argument("graph", metavar="GRAPH", help="graph file")
    p.add_argument("--out", metavar="FILE", help="write here (default: print it)")
    p.add_argument(
        "--graph-path",
        default="/etc/facesynth/graph.toml",
        help="where the graph is mounted in the containers (default /etc/facesynth/graph.toml)",
    )

    p = add(
        "calibrate",
        commands.cmd_calibrate,
        "record a performer's neutral face and expression ranges (guided, or from a video)",
    )
    p.add_argument("name", help="calibration name (then: --calibration NAME)")
    add_stage_arguments(p, ["sensor", "points"])
    p.add_argument(
        "--schedule",
        metavar="STEP=START-END,…",
        help="for a video: when each step happens, in seconds, e.g. neutral=0-2,smile=5-7",
    )
    p.add_argument(
        "--steps",
        default="neutral,raise_eyebrows,frown,look_left,look_right,look_up,look_down,"
        "raise_cheeks,open_mouth,smile",
        help="live camera: the steps to guide through, in order (default: the paper's ten)",
    )
    p.add_argument(
        "--seconds", type=float, default=4.0, help="live camera: seconds per step (default 4)"
    )
    p.add_argument("--out", help="output file (default ~/.config/facesynth/calibrations/NAME.json)")
    p.add_argument("--log-level", default="WARNING", choices=("DEBUG", "INFO", "WARNING", "ERROR"))

    p = add("router", commands.cmd_router, "run a Zenoh router (for hosts without zenohd)")
    _zenoh_arguments(p)
    group = p.add_argument_group("scheduling (as a node's realtime, nice, cpus)")
    group.add_argument(
        "--realtime",
        type=int,
        metavar="PRIORITY",
        help="real-time priority (SCHED_FIFO 1-99; needs CAP_SYS_NICE or ulimit -r)",
    )
    group.add_argument("--nice", type=int, help="niceness -20..19 (negative needs CAP_SYS_NICE)")
    group.add_argument(
        "--cpus",
        type=lambda text: [int(cpu) for cpu in text.split(",") if cpu.strip()],
        metavar="0,1",
        help="cores the router may run on",
    )
    p.set_defaults(mode="router")

    p = add("status", commands.cmd_status, "list live services and their stats")
    _zenoh_arguments(p)
    p.add_argument("--all-rigs", action="store_true", help="every rig, not just --rig")
    p.add_argument(
        "--timeout", type=float, default=2.5, help="seconds to listen for stats (default 2.5)"
    )

    p = add("profile", commands.cmd_profile, "list or check robot profiles")
    p.add_argument("action", choices=("list", "check", "show"))
    p.add_argument("name", nargs="?", help="profile name or TOML path (check, show)")

    p = add(
        "bench",
        commands.cmd_bench,
        "benchmarks: the five-process chain, the tracker, smoothing, recording, the live face "
        "page, expression fidelity",
    )
    p.add_argument(
        "what",
        choices=("chain", "fanout", "tracker", "smoothing", "recording", "face", "fidelity"),
    )
    p.add_argument("video", nargs="?", help="video (default: the bundled performer video)")
    p.add_argument(
        "--seconds",
        type=float,
        default=None,
        help="chain: seconds of real-time input (default 15); fanout: per run (default 10); "
        "face: seconds per row (default 3)",
    )
    p.add_argument(
        "--rate", type=float, default=100.0, help="face: commands per second (default 100)"
    )
    p.add_argument(
        "--fps", type=float, default=30.0, help="chain, recording: frame rate (default 30)"
    )
    p.add_argument(
        "--openface-csv", metavar="PATH", help="chain: replay these landmarks instead of tracking"
    )
    p.add_argument(
        "--frames", type=int, help="tracker: frames to measure (default: the whole video)"
    )
    p.add_argument(
        "--encoding",
        default="jpeg",
        metavar="A,B",
        help="chain: frame encodings to compare, jpeg and/or raw (default jpeg; raw frames go "
        "through Zenoh's shared memory between processes on one host)",
    )
    p.add_argument(
        "--threads", default="1", metavar="N,M", help="chain: tracker inference threads to compare"
    )
    p.add_argument(
        "--robots",
        default="1,4,8,16,32",
        metavar="N,M",
        help="fanout: robot counts to sweep (default 1,4,8,16,32)",
    )
    p.add_argument(
        "--layout",
        default="processes,shared",
        metavar="A,B",
        help="fanout: how robots' nodes share processes, compared side by side: processes (one "
        "per translator and per control interface), robot (one per robot), shared (one for all "
        "robots), shared:K (K processes); default processes,shared",
    )
    p.add_argument(
        "--sched",
        default="normal",
        metavar="A,B",
        help="chain, fanout: scheduling of every process to compare: normal and/or realtime "
        "(SCHED_FIFO priority 10; needs CAP_SYS_NICE)",
    )
    p.add_argument(
        "--baseline",
        metavar="DIR",
        help="chain: also run each variant (without realtime) from this facesynth source tree, "
        "e.g. an older version: git archive v1 | tar -x -C DIR",
    )
    p.add_argument(
        "--runs",
        type=int,
        default=1,
        metavar="N",
        help="chain: N interleaved runs of every variant (default 1; the goals ask for 3)",
    )
    p.add_argument(
        "--hops",
        action="store_true",
        help="chain: also time each hop and show which hops grow in the slowest frames "
        "(the observer then receives every stage's messages, which costs some CPU)",
    )
    p.add_argument("--profile", default="paper16", help="smoothing: profile to measure")
    p.add_argument(
        "--track", help="smoothing: a facesynth track file to measure tracking noise from"
    )
    p.add_argument(
        "--mode",
        default="client",
        metavar="A,B",
        help="chain: Zenoh modes of the services to compare, client and/or peer (default client)",
    )
    p.add_argument(
        "--backends", default="litert,opencv", help="tracker: inference backends to compare"
    )
    p.add_argument(
        "--models",
        metavar="A,B",
        help="tracker models to compare (tracker, fidelity: default fast,full; chain, fanout: "
        "default full)",
    )
    p.add_argument(
        "--profiles",
        metavar="A,B",
        help="fidelity: profiles to measure (default: every shipped one)",
    )
    p.add_argument(
        "--repeat",
        type=int,
        default=1,
        metavar="N",
        help="tracker: N interleaved runs, medians reported (default 1; shared machines: 5)",
    )
    p.add_argument(
        "--mediapipe-python",
        metavar="PATH",
        help="tracker: also time MediaPipe's own trackers with this Python (a venv with "
        "mediapipe==0.10.21; see facesynth/app/bench/mediapipe_helper.py)",
    )
    p.add_argument(
        "--mediapipe-task",
        metavar="PATH",
        help="tracker: the face_landmarker.task bundle for --mediapipe-python",
    )
    p.add_argument(
        "--minutes", type=float, default=10.0, help="recording: session length (default 10)"
    )

    p = add(
        "track", commands.cmd_track, "track a video offline: one JSON line of landmarks per frame"
    )
    p.add_argument("video")
    p.add_argument("--out", required=True, help="output JSON-lines file")
    p.add_argument(
        "--inference",
        choices=backend_choices(),
        default="auto",
        help="inference runtime (default auto: LiteRT when installed)",
    )
    _model_arguments(p)

    from facesynth.app.recording.cli import add_recording_parsers

    add_recording_parsers(sub, _zenoh_arguments)
    return parser


def _model_arguments(parser: argparse.ArgumentParser) -> None:
    """``--model`` (choices and help from the tracker-model registry) and ``--no-blendshapes``."""
    from services.points.tracker.landmarkers import TRACKER_MODELS

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


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``facesynth`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=getattr(args, "log_level", "INFO"),
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
        stream=sys.stderr,
    )
    handler: Any = args.handler
    try:
        return int(handler(args))
    except ValueError as exc:  # every facesynth error about options, files and messages
        print(f"facesynth {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except DriverError as exc:  # an output that cannot be opened (device, file, port in use)
        print(f"facesynth {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # the reader went away (e.g. `| head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
