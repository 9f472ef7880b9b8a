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
from facesynth.app import router_wait, status
from facesynth.app.bench.command import add_bench_arguments, cmd_bench
from facesynth.app.control_tools import add_tool_arguments
from facesynth.app.firmware import add_firmware_arguments, cmd_firmware
from facesynth.app.graph import graph_help
from facesynth.app.library_logs import quiet_libraries
from facesynth.app.recording.attach import add_attach_arguments
from facesynth.app.stage_args import add_stage_arguments
from facesynth.app.usage import parse_arguments
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
    "control": "C: drive servos (or record) from …/servo_commands; `control test` and "
    "`control status` are bring-up tools for a servo board",
}


def _router_timeout(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not 0 <= value <= 86400:
        raise argparse.ArgumentTypeError(f"must be from 0 to 86400 seconds, not {text}")
    return value


def _zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    command = parser.prog.rsplit(" ", 1)[-1]
    kind = router_wait.KINDS[command]  # every command with a Zenoh session has its kind
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
            type=_router_timeout,
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
    p.add_argument("graph", nargs="?", metavar="GRAPH", help=graph_help())
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
        "landmarks | virtual face | servo bars of the translator's profile); after Ctrl-C, of "
        "the frames played so far (Ctrl-C again skips it); see render",
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
            add_tool_arguments(p)

    p = add(
        "render",
        commands.cmd_render,
        "write the side-by-side video of a chain's input video: performer with landmarks | "
        "virtual face | servo bars, one output frame per input frame",
    )
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

    p = add(
        "certs",
        commands.cmd_certs,
        "make a rig's CA, a certificate per service and the Zenoh configs of a secured rig "
        "(mutual TLS, access control)",
    )
    p.add_argument("rig", metavar="RIG", help="rig name (the configs' access control is for it)")
    p.add_argument("--out", default="certs", help="folder to write to (default ./certs)")
    p.add_argument(
        "--router-host",
        action="append",
        default=[],
        metavar="NAME",
        help="a host name or IP address clients reach the router by, put in its certificate "
        "(repeatable; 'router', 'localhost' and 127.0.0.1 are always in)",
    )
    p.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="the router endpoint written into the service configs (repeatable; default "
        "tls/localhost:7447)",
    )
    p.add_argument(
        "--listen",
        action="append",
        metavar="ENDPOINT",
        help="the endpoint written into the router config (default tls/0.0.0.0:7447)",
    )
    p.add_argument(
        "--cert-dir",
        metavar="PATH",
        help="where the hosts will keep these files, as the configs name them "
        "(default: --out, absolute)",
    )
    p.add_argument(
        "--identity",
        action="append",
        metavar="NAME",
        help="issue only these identities (repeatable; default all: sensor, points, features, "
        "translator, control, observer, router)",
    )
    p.add_argument(
        "--days", type=int, default=825, help="validity of the certificates (default 825 days)"
    )
    p.add_argument(
        "--force", action="store_true", help="reissue certificates that exist (the CA is kept)"
    )
    p.add_argument(
        "--configs-only",
        action="store_true",
        help="write only the Zenoh configs (no keys or certificates)",
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

    p = add(
        "firmware",
        cmd_firmware,
        "the Arduino Uno servo firmware: build it (gcc-avr) or flash it to a board (avrdude)",
    )
    add_firmware_arguments(p)

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

    p = add("status", status.cmd_status, "list live services and their stats")
    _zenoh_arguments(p)
    p.add_argument("--all-rigs", action="store_true", help="every rig, not just --rig")
    p.add_argument(
        "--timeout", type=float, default=2.5, help="seconds to listen for stats (default 2.5)"
    )

    p = add(
        "health",
        status.cmd_health,
        "exit 0 if a service of this host holds its liveliness token on the router (or, with "
        "--router, if the router accepts sessions); 1 if not: a container health check",
    )
    _zenoh_arguments(p)
    p.add_argument(
        "--router", action="store_true", help="check that the router accepts a session instead"
    )
    p.add_argument(
        "--host",
        help="whose services to look for: instance ids start with this host name "
        "(default: this host's)",
    )
    p.add_argument(
        "--timeout", type=float, default=3.0, help="seconds to wait for answers (default 3)"
    )

    p = add("profile", commands.cmd_profile, "list or check robot profiles")
    p.add_argument("action", choices=("list", "check", "show"))
    p.add_argument("name", nargs="?", help="profile name or TOML path (check, show)")

    p = add(
        "bench",
        cmd_bench,
        "benchmarks: the five-process chain, the tracker, smoothing, recording, the live face "
        "page, expression fidelity, servo drivers on the wire",
    )
    add_bench_arguments(p)

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
    from facesynth.app.learn.arguments import add_learn_parser

    add_learn_parser(sub, _zenoh_arguments)
    from facesynth.app.simhead.command import add_simhead_parser

    add_simhead_parser(sub)
    from facesynth.app.doctor.command import add_doctor_parser

    add_doctor_parser(sub, _zenoh_arguments)
    from facesynth.app.console.arguments import add_console_parser

    add_console_parser(sub, _zenoh_arguments)
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
    args = parse_arguments(parser, argv)
    logging.basicConfig(
        level=getattr(args, "log_level", "INFO"),
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
        stream=sys.stderr,
    )
    quiet_libraries(getattr(args, "log_level", "INFO"))
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
