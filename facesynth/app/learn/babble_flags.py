"""How a robot is posed and its face read while babbling (``facesynth learn``) or rehearsing a
plan (``facesynth plan --camera``): the command-line flags, declared without importing what
runs them, and the :class:`~facesynth.app.learn.core.BabbleOptions` they give."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from facesynth.app.learn.core import BabbleOptions

__all__ = ["BABBLE_FLAGS", "add_babble_flags", "babble_options"]

#: How babbling moves and settles: flag, type, default, help (which ends with the default).
BABBLE_FLAGS: tuple[tuple[str, type[float] | type[int], float, str], ...] = (
    ("--pace", float, 0.8, "command speed as a fraction of each servo's max_speed (0.8)"),
    ("--settle-frames", int, 4, "frames the face must hold still (4)"),
    ("--settle-tolerance", float, 0.05, "largest change of the features over those frames (0.05)"),
    (
        "--min-wait",
        float,
        0.25,
        "seconds after the servos got there before the face's frames count (0.25)",
    ),
    ("--max-wait", float, 3.0, "longest wait for a pose to settle (3 s)"),
    (
        "--measured-tolerance",
        float,
        20.0,
        "where the driver reads the servos back: how close (µs) "
        "their measured positions must come to the command; no --min-wait then (20)",
    ),
    (
        "--measured-timeout",
        float,
        3.0,
        "seconds a read-back servo may take to get there before the pose is taken (3)",
    ),
    ("--frame-every", int, 30, "record every Nth camera frame into the session (30; 0: none)"),
)


def add_babble_flags(group: argparse._ArgumentGroup | argparse.ArgumentParser) -> None:
    """Every one of :data:`BABBLE_FLAGS` on ``group``."""
    for flag, kind, default, what in BABBLE_FLAGS:
        group.add_argument(flag, type=kind, default=default, help=what)


def babble_options(args: argparse.Namespace) -> BabbleOptions:
    """The pace and the settling the flags ask for."""
    from facesynth.app.learn.core import BabbleOptions
    from facesynth.app.learn.settle import SettleOptions

    return BabbleOptions(
        settle=SettleOptions(
            frames=args.settle_frames,
            feature_tol=args.settle_tolerance,
            max_wait_s=args.max_wait,
            min_wait_s=args.min_wait,
            measured_tol_us=args.measured_tolerance,
            measured_timeout_s=args.measured_timeout,
        ),
        pace=args.pace,
    )
