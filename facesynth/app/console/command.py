"""``facesynth console``: the rig console, one rig, run until Ctrl-C.

An embedded Zenoh router (as ``facesynth run`` opens; the chain's stage commands join it as
clients), the control interface C with the chosen driver and profile in this process, the
:class:`~facesynth.app.console.session.ConsoleSession` and its
:class:`~facesynth.app.console.server.ConsoleServer`. One console per rig on a computer: a lock
file says which process holds it. At start it prints the page's address with its token.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import fcntl
import logging
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgspec

from facesynth.app.chain import freeze_startup_objects
from facesynth.app.console.calibration import CalibrationRun
from facesynth.app.console.profile_file import save_path
from facesynth.app.console.rig import ConsoleRig
from facesynth.app.engine.router import RUN_LISTEN, embedded_bus
from facesynth.app.graph import Graph
from facesynth.app.nodes import ControlNode, SensorNode
from facesynth.app.profile_choice import check_fit
from facesynth.app.robot_rig import preflight
from facesynth.app.stage_args import PLUGIN_FLAGS, apply_arguments
from facesynth.app.wiring import OptionError, StageParts, build_node, zenoh_options
from facesynth.runtime.bus.zenoh_bus import endpoints
from facesynth.runtime.keys import check_name
from facesynth.runtime.outputs import check_output
from facesynth.runtime.profiles import load_profile, resolve_profile
from facesynth.runtime.service import run_async, until_signalled
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.virtual import AddressError, parse_address
from facesynth.services.features.calibrate import parse_schedule

log = logging.getLogger("facesynth.console")


def parse_page(text: str) -> tuple[str, int]:
    """``--page HOST:PORT`` as (host, port); ``OptionError`` when it is not one."""
    try:
        return parse_address(text)
    except AddressError:
        raise OptionError(f"--page {text!r} is not HOST:PORT (e.g. 127.0.0.1:8095)") from None


def lock_path(rig: str) -> Path:
    """The lock file of a rig's console on this computer."""
    folder = os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir()
    return Path(folder) / f"facesynth-console-{rig}.lock"


@contextlib.contextmanager
def rig_lock(rig: str) -> Iterator[None]:
    """Hold the rig's console lock, or ``OptionError`` naming the process that holds it."""
    path = lock_path(rig)
    handle = open(path, "a+")  # noqa: SIM115 - held for the whole run
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "another process"
            raise OptionError(
                f"another facesynth console runs rig {rig!r} (pid {holder}): one console "
                "moves the servos at a time"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(str(os.getpid()))
        handle.flush()
        yield
    finally:
        handle.close()


def check_source(config: msgspec.Struct) -> None:
    """A camera or video that cannot be what it says is refused at start (``SourceError``),
    not when the page asks for a calibration; nothing is opened."""
    from facesynth.services.sensor.sources.camera import CameraConfig, camera_target

    if isinstance(config, CameraConfig):
        camera_target(config.index)
    path = getattr(config, "path", None)
    if isinstance(path, str) and path and not Path(path).is_file():
        raise OptionError(f"--video {path}: no such file")


def _calibration_factory(args: argparse.Namespace) -> Any:
    """Makes a :class:`CalibrationRun` per request when a camera or video was given."""
    if not PLUGIN_FLAGS["sensor"][0].chosen(args):
        if args.schedule:
            raise OptionError(
                "--schedule needs --video FILE (or --camera N): without one the console "
                "cannot calibrate"
            )
        return None
    if args.schedule:
        parse_schedule(args.schedule)  # a bad schedule is refused now, not on the page
    _, config = apply_arguments("sensor", SensorNode(), args)  # its options, checked now
    check_source(config)
    out_dir = Path(args.calibrations) if args.calibrations else None
    return lambda name: CalibrationRun(name, args, out_dir)


def cmd_console(args: argparse.Namespace) -> int:
    """``facesynth console --profile NAME --driver NAME …``."""
    host, port = parse_page(args.page)
    for flag, url in (("--face-page", args.face_page), ("--robot-camera", args.robot_camera)):
        if url is not None and not url.startswith(("http://", "https://")):
            raise OptionError(f"{flag} {url!r}: give an http:// or https:// address")
    if not hasattr(args, "opt_profile"):
        raise OptionError(
            "console needs --profile NAME (the head's profile to bring up, e.g. head16_hardware)"
        )
    if not PLUGIN_FLAGS["control"][0].chosen(args):
        raise OptionError(f"console needs --driver NAME ({', '.join(DRIVERS.names())})")
    node, config = apply_arguments("control", ControlNode(), args)
    profile_file = node.profile or ""  # given: checked above
    profile = load_profile(profile_file)
    check_fit(config, profile)
    core = ConsoleRig(profile)
    save_to = (
        Path(args.save) if args.save else save_path(resolve_profile(profile_file), profile.name)
    )
    if save_to.suffix != ".toml":
        raise OptionError(f"--save {save_to}: a profile file ends in .toml")
    check_output(save_to, "profile", make_parents=True)
    rig = args.rig or "default"
    check_name(rig, "rig")
    calibration = _calibration_factory(args)
    if DRIVERS.build(config, profile).moves_hardware:
        run_async(preflight(config, profile))
    graph = Graph(rig=rig, nodes={"control": node})

    def control(profile_file: str) -> StageParts:
        changed = msgspec.structs.replace(node, profile=profile_file)
        return build_node("control", changed, graph, config)

    with rig_lock(rig):
        return run_async(_serve(args, rig, core, control, node, save_to, host, port, calibration))


async def _serve(
    args: argparse.Namespace,
    rig: str,
    core: ConsoleRig,
    control: Any,
    node: ControlNode,
    save_to: Path,
    host: str,
    port: int,
    calibration: Any,
) -> int:
    from facesynth.app.console.server import ConsoleServer
    from facesynth.app.console.session import ConsoleSession

    listen = endpoints(args.listen) or [RUN_LISTEN]
    zenoh = zenoh_options(args, default_mode="router")
    zenoh.connect = endpoints(args.connect)
    async with embedded_bus(listen, zenoh, rig=rig) as (bus, locators):
        session = ConsoleSession(
            bus, rig, core, control, profile_file=node.profile or "", save_to=save_to,
            stats_interval=args.stats_interval, robot=node.robot,
        )  # fmt: skip
        views = {"face_page": args.face_page, "robot_camera": args.robot_camera}
        server = ConsoleServer(session, host=host, port=port, calibration=calibration, views=views)
        try:
            try:
                await server.start()
            except OSError as exc:
                raise OptionError(
                    f"--page {args.page}: cannot listen there ({exc.strerror})"
                ) from None
            await session.start()
            freeze_startup_objects()
            print(f"facesynth console for rig {rig}: {server.url}", flush=True)
            print(f"router: {', '.join(locators)} (the chain's stages join it)", flush=True)
            print(f"profile {core.active.name}: Save writes {save_to}", flush=True)
            await until_signalled(asyncio.Event().wait())
        finally:
            await server.stop()
            await session.stop()
    return 0
