"""``facesynth status`` and ``facesynth health`` (implemented in :mod:`facesynth.app.status`)."""

from __future__ import annotations

import argparse

from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import zenoh_arguments
from facesynth.app.status import cmd_health, cmd_status

STATUS_HELP = "list live services and their stats"


def _status_arguments(p: argparse.ArgumentParser) -> None:
    zenoh_arguments(p)
    p.add_argument("--all-rigs", action="store_true", help="every rig, not just --rig")
    p.add_argument(
        "--timeout", type=float, default=2.5, help="seconds to listen for stats (default 2.5)"
    )


HEALTH_HELP = (
    "exit 0 if a service of this host holds its liveliness token on the router (or, with "
    "--router, if the router accepts sessions); 1 if not: a container health check"
)


def _health_arguments(p: argparse.ArgumentParser) -> None:
    zenoh_arguments(p)
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


COMMANDS = (
    Command("status", STATUS_HELP, cmd_status, _status_arguments),
    Command("health", HEALTH_HELP, cmd_health, _health_arguments),
)
