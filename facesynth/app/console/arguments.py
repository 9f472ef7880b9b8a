"""The arguments of ``facesynth console``, declared without importing what the command runs
(aiohttp, the tracker: :mod:`facesynth.app.console.command` is imported when it runs)."""

from __future__ import annotations

import argparse

from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import calibration_step_arguments, zenoh_arguments
from facesynth.app.stage_args import add_stage_arguments

HELP = (
    "the rig console in the browser: jog each servo through C, find and save its limits, "
    "calibrate the performer, watch the chain (one rig; loopback and a token by default)"
)


def _cmd_console(args: argparse.Namespace) -> int:
    from facesynth.app.console.command import cmd_console

    return cmd_console(args)


def _arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth console``'s arguments."""
    p.add_argument(
        "--page",
        default="127.0.0.1:8095",
        metavar="HOST:PORT",
        help="where the page is served (default 127.0.0.1:8095: this computer only; port 0 = "
        "any free port). Another host needs the token too",
    )
    p.add_argument(
        "--save",
        metavar="FILE.toml",
        help="where Save writes the profile (default: the profile's own file, or for a profile "
        "shipped with facesynth ~/.config/facesynth/profiles/NAME.toml, found first by name); "
        "the previous file is kept as FILE.toml.bak",
    )
    p.add_argument(
        "--face-page",
        metavar="URL",
        help="show this live face page beside the performer (a virtual driver's --http page)",
    )
    p.add_argument(
        "--robot-camera",
        metavar="URL",
        help="show this MJPEG camera beside the performer (e.g. facesynth simhead's camera: URL)",
    )
    group = p.add_argument_group("performer calibration (with --camera N or --video FILE)")
    calibration_step_arguments(group)
    group.add_argument(
        "--calibrations",
        metavar="DIR",
        help="where calibrations are written (default ~/.config/facesynth/calibrations, where "
        "--calibration NAME finds them)",
    )
    add_stage_arguments(p, ["sensor", "points", "control"])
    zenoh_arguments(p)


COMMANDS = (Command("console", HELP, _cmd_console, _arguments),)
