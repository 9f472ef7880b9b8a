"""``facesynth calibrate NAME``: a performer's neutral face and expression ranges."""

from __future__ import annotations

import argparse
import logging

from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import calibration_step_arguments
from facesynth.app.stage_args import add_stage_arguments

log = logging.getLogger("facesynth")


def cmd_calibrate(args: argparse.Namespace) -> int:
    """``facesynth calibrate NAME``."""
    from facesynth.app.calibrate_cli import run_calibration

    run_calibration(args)
    return 0


HELP = "record a performer's neutral face and expression ranges (guided, or from a video)"


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("name", help="calibration name (then: --calibration NAME)")
    add_stage_arguments(p, ["sensor", "points"])
    calibration_step_arguments(p)
    p.add_argument("--out", help="output file (default ~/.config/facesynth/calibrations/NAME.json)")
    p.add_argument("--log-level", default="WARNING", choices=("DEBUG", "INFO", "WARNING", "ERROR"))


COMMANDS = (Command("calibrate", HELP, cmd_calibrate, _arguments),)
