"""The arguments of ``facesynth learn``, declared without importing what the command runs.

``facesynth`` builds every sub-command's parser at start-up, on a servo board too, where the
recording and tracker extras that babbling needs are not installed: the command's modules
(:mod:`facesynth.app.learn.cli`) are imported only when ``facesynth learn`` runs.
"""

from __future__ import annotations

import argparse

from facesynth.app.command_registry import Command
from facesynth.app.common_arguments import zenoh_arguments
from facesynth.app.learn.babble_flags import add_babble_flags, add_rig_flags

#: The adaptive plan's own options (docs/learning.md); a resume keeps the session's.
ADAPTIVE_FLAGS = (
    ("--region-poses", "poses that move one region of the face after the sweeps (250)"),
    ("--batch", "least-sure poses chosen at a time (25)"),
    ("--candidates", "random poses each batch is chosen from (400)"),
    ("--members", "self-models in the ensemble that judges them (5)"),
)


def _cmd_learn(args: argparse.Namespace) -> int:
    from facesynth.app.learn.cli import cmd_learn

    return cmd_learn(args)


def _arguments(p: argparse.ArgumentParser) -> None:
    """``facesynth learn``'s arguments."""
    p.add_argument("--profile", help="the robot's hardware profile: NAME or TOML path")
    p.add_argument(
        "--out",
        dest="session",
        metavar="SESSION.mcap",
        help="the babbling session file; an existing one is resumed",
    )
    p.add_argument("--poses", type=int, help="babble until the session holds N poses (default 600)")
    p.add_argument("--minutes", type=float, help="babble at most M minutes in this run")
    p.add_argument("--seed", type=int, help="the plan's seed (default 0; a resume keeps its own)")
    p.add_argument(
        "--fit-only", metavar="SESSION.mcap", help="do not babble: fit this session's poses"
    )
    p.add_argument("--no-fit", action="store_true", help="babble only, fit later (--fit-only)")
    p.add_argument(
        "--partial",
        action="store_true",
        help="fit a session that has not yet swept every servo: those stay at neutral "
        "(without it the fit refuses, naming them)",
    )
    p.add_argument(
        "--out-profile",
        metavar="NAME.learned",
        help="the learned profile to write (default: the session's name with .learned, beside "
        "it; in ~/.config/facesynth/profiles it is found by name)",
    )
    group = p.add_argument_group("babbling")
    group.add_argument(
        "--neutral-every",
        type=int,
        help="a neutral pose every K poses (25; a resume keeps the session's)",
    )
    group.add_argument(
        "--plan",
        metavar="PLAN",
        help="the babbling plan: fixed (sweeps, then poses that fill the space), adaptive "
        "(finer sweeps, then poses chosen from the faces seen so far) or stream (sweeps, then "
        "the head kept moving and every camera frame learned from, for --minutes, default 10; "
        "docs/learning.md); default fixed, a resume keeps its own",
    )
    group.add_argument(
        "--sweep-steps",
        type=int,
        help="steps of each servo's sweep each way (3; 6 with --plan adaptive; a resume keeps "
        "the session's)",
    )
    for flag, what in ADAPTIVE_FLAGS:
        group.add_argument(flag, type=int, help=f"--plan adaptive: {what}")
    add_babble_flags(group)
    add_rig_flags(p, {"--out", "--profile"})
    zenoh_arguments(p)


HELP = (
    "the robot learns its own face: babble the servos in front of the robot's camera, "
    "record every settled pose (resumable), fit the self-model, write a learned profile"
)

COMMANDS = (Command("learn", HELP, _cmd_learn, _arguments),)
