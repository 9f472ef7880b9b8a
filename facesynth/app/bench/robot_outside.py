"""``facesynth bench robot --driver … --camera …``: every profile on a head outside this
process, in real time (:mod:`.robot_live`), each learned one also with its loop closed through
that camera (``--closed-loop``) or its plan of the whole video played (``--planned``).

The head's rig comes from the same flags as ``facesynth learn`` takes
(:mod:`facesynth.app.learn.babble_flags`): any servo driver with its options, and any live
camera source; a board that is not there, or a camera that cannot open, is said before the
performer is tracked.
"""

from __future__ import annotations

import argparse
import asyncio
from collections.abc import Callable, Coroutine, Sequence
from typing import Any

import msgspec

from facesynth.app.arguments import OptionError
from facesynth.app.learn.babble_flags import camera_given, driver_given
from facesynth.app.stage_args import PLUGIN_FLAGS
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.base import ServoDriver

from .robot import Performance, RobotBench, measure, track_performer
from .robot_closed import CLOSED_SUFFIX
from .robot_compare import FeatureStream
from .robot_live import CameraFeed, live_closed, live_profile
from .robot_planned import PLANNED_SUFFIX
from .robot_variants import every_way

__all__ = ["bench_outside", "head_rig", "where"]

#: A way to run a learned profile on the head: the performance, the profile, its driver and
#: the camera → the robot's raw features.
LiveWay = Callable[
    [Performance, Profile, ServoDriver, CameraFeed], Coroutine[Any, Any, FeatureStream]
]


async def _closed(
    performance: Performance, profile: Profile, driver: ServoDriver, camera: CameraFeed
) -> FeatureStream:
    return (await live_closed(performance, profile, driver, camera))[0]


async def _planned(
    performance: Performance, profile: Profile, driver: ServoDriver, camera: CameraFeed
) -> FeatureStream:
    return await live_profile(performance, profile, driver, camera, planned=True)


#: ``--closed-loop`` and ``--planned`` on a head outside this process: suffix and way.
WAYS: dict[str, tuple[str, LiveWay]] = {
    "closed_loop": (CLOSED_SUFFIX, _closed),
    "planned": (PLANNED_SUFFIX, _planned),
}


def head_rig(args: argparse.Namespace) -> tuple[msgspec.Struct, msgspec.Struct, str]:
    """The camera's and the servo driver's checked configs for a head outside this process,
    from the same flags as ``facesynth learn`` takes, and the head's name in the report
    (``DRIVER PORT | SOURCE WHERE``).

    Raises:
        OptionError: no driver or no camera, a simulated ``--head`` beside them, or options
            that do not fit the plugins chosen.
    """
    if not (driver_given(args) and camera_given(args)):
        raise OptionError(
            "a head outside this process needs both --driver and --camera (or --ros2-image-topic)"
        )
    if args.head:
        raise OptionError("--head names a simulated head in process; with --driver, omit it")
    camera = PLUGIN_FLAGS["sensor"][0].config(args, None)
    driver = PLUGIN_FLAGS["control"][0].config(args, None)
    return camera, driver, f"{where(driver)} | {where(camera)}"


def where(config: msgspec.Struct) -> str:
    """A plugin config as the report names it: its plugin and, if it has them, the place it
    reads or writes (a port, a bus, a camera, a topic)."""
    data = msgspec.to_builtins(config)
    places = ("port", "bus", "index", "topic")
    return " ".join(str(data[k]) for k in (next(iter(data)), *places) if data.get(k) is not None)


def bench_outside(
    args: argparse.Namespace,
    profiles: Sequence[Profile],
    ways: Sequence[str],
    progress: Callable[[str], None],
    calibration: Calibration | None = None,
) -> RobotBench:
    """Every profile on the head behind ``--driver`` (any servo driver, with its options),
    watched through ``--camera`` (or the robot's camera on ROS 2, ``--ros2-image-topic``);
    each learned one again each of ``ways`` (``closed_loop``, ``planned``), named ``NAME`` +
    the way's suffix."""
    from facesynth.app.data import sample_video
    from facesynth.app.robot_rig import preflight
    from facesynth.runtime.service import run_async
    from facesynth.services.control.drivers.registry import DRIVERS
    from facesynth.services.sensor.sources.registry import SOURCES

    camera, driver, name = head_rig(args)
    if DRIVERS.build(driver, profiles[0]).moves_hardware:  # a board that is not there: now
        run_async(preflight(driver, profiles[0]))
    source = SOURCES.build(camera)  # a camera that cannot open: before any tracking
    if not source.info.live:
        source.close()
        raise OptionError(
            f"source {where(camera)} is not a live camera: bench robot watches the head as "
            "it moves (--camera or --ros2-image-topic)"
        )
    feed = CameraFeed(source)
    chosen = dict(WAYS[way] for way in ways)
    try:
        progress("tracking the performer")
        performance = track_performer(
            args.video or str(sample_video()), frames=args.frames, calibration=calibration
        )

        def run(head: str, profile: Profile) -> FeatureStream:
            way: LiveWay = live_profile
            for suffix, other in chosen.items():
                if profile.name.endswith(suffix):
                    name = profile.name.removesuffix(suffix)
                    profile, way = msgspec.structs.replace(profile, name=name), other
            output = DRIVERS.build(driver, profile)
            return asyncio.run(way(performance, profile, output, feed))

        every = [way for profile in profiles for way in every_way(profile, chosen)]
        return measure(performance, [name], every, run, progress=progress)
    finally:
        feed.close()
