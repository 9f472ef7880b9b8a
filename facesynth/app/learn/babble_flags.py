"""How a robot is posed and its face read while babbling (``facesynth learn``) or rehearsing a
plan (``facesynth plan --driver … --camera …``): the command-line flags, declared without
importing what runs them, the :class:`~facesynth.app.learn.core.BabbleOptions` they give, and
the robot's rig they name (:func:`add_rig_flags`: every camera source's, tracker's and servo
driver's flags, from their registries; :func:`rig_configs`: their checked configs)."""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from facesynth.app.arguments import OptionError, flag_dest
from facesynth.app.stage_args import PLUGIN_FLAGS

if TYPE_CHECKING:
    import msgspec

    from facesynth.app.learn.core import BabbleOptions

__all__ = [
    "BABBLE_FLAGS",
    "RIG_DEFAULTS",
    "add_babble_flags",
    "add_rig_flags",
    "babble_options",
    "camera_given",
    "driver_given",
    "rig_configs",
    "rig_flags_given",
]

#: The robot rig's stages and the plugin each runs when the command line names none (no
#: camera: one must be given; the servo driver ``record``: a dry run writes the commands).
RIG_DEFAULTS: dict[str, str | None] = {"sensor": None, "points": "tracker", "control": "record"}
#: Where argparse keeps ``--newest-frame``/``--no-newest-frame`` (default here: on).
NEWEST_FRAME = flag_dest("--newest-frame")

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


def add_rig_flags(
    parser: argparse.ArgumentParser,
    seen: set[str],
    defaults: Mapping[str, str | None] = RIG_DEFAULTS,
    purposes: Mapping[str, str] | None = None,
) -> None:
    """The robot's camera (``--camera``, ``--ros2-image-topic``, … ``--video`` for a dry run),
    the tracker on its frames and its servo driver (``--driver`` with every driver's options,
    ``--driver-config FILE``), from the plugin registries; ``seen``: flags ``parser`` has
    (they keep their meaning there). ``defaults``: the rig's stages to take, each with the
    plugin its help names as the default (``facesynth bench robot``: camera and driver only);
    ``purposes``: what each stage's group is for, in ``--help``."""
    for stage, default in defaults.items():
        flags, _ = PLUGIN_FLAGS[stage]
        flags.add(parser, seen, default, (purposes or {}).get(stage))


def camera_given(args: argparse.Namespace) -> bool:
    """Whether the command line names the robot's camera (a source, or a flag that picks one)."""
    return PLUGIN_FLAGS["sensor"][0].chosen(args)


def driver_given(args: argparse.Namespace) -> bool:
    """Whether the command line names the robot's servo driver (``--driver``,
    ``--driver-config``)."""
    return PLUGIN_FLAGS["control"][0].chosen(args)


def rig_flags_given(args: argparse.Namespace, stages: Iterable[str] = RIG_DEFAULTS) -> list[str]:
    """The rig's flags the command line gives (``--driver``, ``--port``, ``--camera``, …), of
    ``stages`` (default: camera, tracker and driver)."""
    return [flag for stage in stages for flag in PLUGIN_FLAGS[stage][0].given(args)]


def rig_configs(args: argparse.Namespace, record_out: Path) -> dict[str, msgspec.Struct]:
    """The camera's, the tracker's and the servo driver's checked configs from the command
    line (``sensor``, ``points``, ``control``); a camera keeps only its newest frame unless
    ``--no-newest-frame``, and the ``record`` driver writes to ``record_out``.

    Raises:
        OptionError: no camera given, or flags that do not fit the plugins chosen.
    """
    from facesynth.app.robot_rig import newest

    if not camera_given(args):
        raise OptionError("give the robot's camera with --camera (or --video FILE for a dry run)")
    sensor_flags, _ = PLUGIN_FLAGS["sensor"]
    source = sensor_flags.config(args, None)
    if not hasattr(args, NEWEST_FRAME):
        source = newest(source)
    backend = PLUGIN_FLAGS["points"][0].config(args, {"backend": "tracker"})
    driver_base = None
    if getattr(args, "plugin_driver", "record") == "record":
        driver_base = {"driver": "record", "out": str(record_out)}
    driver = PLUGIN_FLAGS["control"][0].config(args, driver_base)
    return {"sensor": source, "points": backend, "control": driver}
