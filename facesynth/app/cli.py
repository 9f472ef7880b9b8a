"""The ``facesynth`` command: the registered sub-commands (one per service, plus run, router,
status, track, bench, …; see :mod:`facesynth.app.command_registry`).

Every service command takes the standard Zenoh options (``--mode``, ``--connect``, ``--listen``,
``--zenoh-config`` or ``ZENOH_CONFIG``, ``--scouting``) and ``--rig``. Errors in options or files
are printed as one clear line and exit with status 2.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Sequence
from typing import Any

from facesynth import __version__
from facesynth.app.command_registry import add_commands
from facesynth.app.library_logs import quiet_libraries
from facesynth.app.usage import parse_arguments
from facesynth.services.control.drivers.base import DriverError


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser: one sub-parser per registered command
    (:mod:`facesynth.app.command_registry`)."""
    parser = argparse.ArgumentParser(
        prog="facesynth",
        description="Real-time facial expression synthesis for robot and virtual faces.",
    )
    parser.add_argument("--version", action="version", version=f"facesynth {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    add_commands(sub)
    return parser


def main(argv: Sequence[str] | None = None, parser: argparse.ArgumentParser | None = None) -> int:
    """Run the command ``argv`` names (``parser``: one :func:`build_parser` made already)."""
    parser = parser or build_parser()
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
