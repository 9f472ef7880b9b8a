"""``facesynth doctor [GRAPH]``: what this host can run, and what to fix, one line each.

It takes ``facesynth run``'s arguments, builds the graph ``run`` would run (flags applied,
profiles settled) without starting anything, and looks at what that graph needs next to what
the host has: cameras, serial boards, the router, the files it writes and reads, the extras,
the firmware. It exits 0 when the graph can run, else 2 with one error line after the lines
that say what to fix.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ThreadPoolExecutor

from facesynth.app import wiring
from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import zenoh_arguments
from facesynth.app.doctor import (
    addresses,
    buses,
    cameras,
    extras,
    firmware_check,
    named,
    outputs,
    ros2,
    router,
)
from facesynth.app.doctor import serial_ports as serial
from facesynth.app.doctor.needs import Needs, RouterNeed, graph_needs
from facesynth.app.doctor.report import Finding, lines, verdict
from facesynth.app.engine.router import RUN_LISTEN
from facesynth.app.graph import Graph, check_node, graph_file, graph_help, load_graph
from facesynth.app.profile_choice import settle_profiles
from facesynth.app.recording.attach import add_attach_arguments
from facesynth.app.stage_args import add_stage_arguments, apply_arguments
from facesynth.app.stages.registry import STAGES
from facesynth.runtime.bus.zenoh_bus import endpoints


class DoctorError(ValueError):
    """The graph cannot run on this host (the lines above say what to fix)."""


def _arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth doctor``'s arguments."""
    p.add_argument("graph", nargs="?", metavar="GRAPH", help=graph_help())
    add_stage_arguments(p, STAGES.names())
    add_attach_arguments(p)
    zenoh_arguments(p)
    p.add_argument("--render", metavar="OUT.mp4", help="as run's: check that it can be written")
    group = p.add_argument_group("doctor")
    group.add_argument(
        "--serial",
        action="append",
        default=[],
        metavar="PORT",
        help="also ask who answers on this serial port (a device path, a pty's link, "
        "socket://HOST:PORT); repeatable. The ports pyserial lists and the graph's are asked "
        "anyway, read-only: nothing moves",
    )
    group.add_argument(
        "--timeout",
        type=float,
        default=2.0,
        metavar="S",
        help="seconds to wait for the router (default 2)",
    )


def router_need(args: argparse.Namespace, graph: Graph | None = None) -> RouterNeed:
    """The graph's link to Zenoh, as ``run`` makes it: its own router unless told otherwise.

    ``run`` of a graph with a sensor (``graph``; None: the demo's, which has one) takes a free
    port when its default endpoint is taken; an explicit ``--listen`` is kept or ``run`` fails,
    and so does a graph without a sensor (its nodes are served where others look for them).
    """
    options = wiring.zenoh_options(args, default_mode="router")
    embedded = options.effective_mode() == "router"
    if embedded and not options.listen and options.config_file_path() is None:
        options.listen = endpoints(args.listen) or [RUN_LISTEN]
    chain = graph is None or bool(graph.sources())
    return RouterNeed(options, embedded, free_port=embedded and chain and not args.listen)


def examine(needs: Needs, serial_ports: list[str], timeout: float) -> list[Finding]:
    """Look at the host for ``needs``: the slow looks (ports, router, cameras) at once."""
    from facesynth.app.firmware import FirmwareError, bundled_version

    devices = cameras.video_devices()
    opencv = cameras.have_opencv()
    targets = cameras.cameras_to_open(devices, needs.cameras) if opencv else []
    ports, unasked = serial.ports_to_probe(needs.serial, serial_ports, serial.listed_ports())
    with ThreadPoolExecutor(max_workers=3) as pool:
        port_results = pool.submit(serial.probe_ports, ports)
        router_result = (
            pool.submit(router.probe_router, needs.router, timeout) if needs.router else None
        )
        camera_results = pool.submit(lambda: [cameras.open_camera(t) for t in targets])
        found_ports = port_results.result() + [
            serial.PortResult(port, unasked=True) for port in unasked
        ]
        found_router = router_result.result() if router_result else None
        found_cameras = camera_results.result()
    try:
        bundled: tuple[int, int, int] | None = bundled_version()
    except FirmwareError:
        bundled = None
    findings = cameras.camera_findings(devices, found_cameras, needs.cameras, opencv=opencv)
    findings += serial.serial_findings(found_ports, needs.serial)
    findings += firmware_check.firmware_findings(found_ports, needs.serial, bundled)
    if found_router is not None and needs.router is not None:
        findings += router.router_findings(found_router, needs.router)
    findings += addresses.address_findings(needs.addresses)
    findings += outputs.output_findings(needs.outputs, needs.folders, outputs.user_folders())
    findings += named.profile_findings(needs.profiles)
    findings += buses.bus_findings(needs.profiles)
    findings += named.calibration_findings(needs.calibrations)
    findings += extras.extras_findings(extras.installed_extras(), needs.extras)
    findings += ros2.ros2_findings("ros2" in needs.extras)
    return findings


def cmd_doctor(args: argparse.Namespace) -> int:
    """``facesynth doctor [GRAPH]``."""
    started = time.monotonic()
    graph = load_graph(args.graph, plugins=False)
    configs = {}
    for name, node in list(graph.nodes.items()):
        graph.nodes[name], configs[name] = apply_arguments(name, node, args)
        check_node(name, graph.nodes[name], args.graph or "command line")
    settle_profiles(graph, configs, check=False)  # a misfit is one of the lines below
    needs = graph_needs(graph, configs, router=router_need(args, graph), options=args)
    findings = examine(needs, args.serial, args.timeout)
    for line in lines(findings):
        print(line, flush=True)
    name = (
        graph_file(args.graph).stem if args.graph is None or "/" not in args.graph else args.graph
    )
    problem = verdict(findings, name)
    if problem is not None:
        raise DoctorError(problem)
    print(f"graph {name} can run on this host ({time.monotonic() - started:.1f} s)")
    return 0


HELP = (
    "say what this host can run and what to fix, one line each: cameras, serial boards, "
    "the router, output folders, extras, firmware; exit 0 when the graph (run's "
    "arguments) can run here"
)

COMMANDS = (Command("doctor", HELP, cmd_doctor, _arguments),)
