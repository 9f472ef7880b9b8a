"""``facesynth bench robot``: its options checked, the heads opened, the result printed."""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
from collections.abc import Callable
from pathlib import Path

import msgspec

from facesynth.app.engine.robot_loop import Head, RobotError
from facesynth.app.learn.babble_flags import camera_given, driver_given, rig_flags_given
from facesynth.app.stage_args import PLUGIN_FLAGS
from facesynth.app.wiring import OptionError
from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.calibration import Calibration, load_calibration
from facesynth.runtime.outputs import check_output
from facesynth.runtime.profiles import Profile

from .arguments import RIG
from .robot import DEFAULT_PROFILES, RobotBench, bench_robot, load, measure, track_performer
from .robot_compare import FeatureStream
from .robot_report import format_robot, robot_json
from .robot_variants import Runner, every_way


def simulated_heads(names: list[str] | None) -> tuple[list[str], Callable[[str], Head]]:
    """The heads to drive (default: every bundled simulated head), each checked now, and a
    function building a fresh one by name."""
    from facesynth.app.simhead import SimHead, head_names, load_head

    chosen = names or head_names()
    configs = {name: load_head(name) for name in chosen}  # a clear error before any tracking
    return chosen, lambda name: SimHead(configs[name])


def profiles_of(args: argparse.Namespace) -> list[str]:
    """``--profile`` (repeated) and ``--profiles A,B``, in order; default the hand-written."""
    chosen = list(args.profile or [])
    chosen += [p.strip() for p in (args.profiles or "").split(",") if p.strip()]
    return chosen or list(DEFAULT_PROFILES)


def performer_calibration(name: str | None) -> Calibration | None:
    """``--calibration NAME|PATH``: the performer's calibration, checked before any tracking
    (None: F takes her neutral from her first second with a face)."""
    if name is None:
        return None
    try:
        return load_calibration(name)
    except ValueError as exc:
        raise RobotError(f"--calibration: {exc}") from None


def bench_robot_command(args: argparse.Namespace) -> int:
    """Every profile on every simulated head in process, or (``--driver``, ``--camera`` or
    ``--ros2-image-topic``) on a head outside it in real time; a table (or ``--json``) on
    stdout."""
    from facesynth.app.data import sample_video
    from facesynth.runtime.profiles import load_profile

    if args.frames is not None and args.frames < 1:
        raise OptionError("--frames must be at least 1")
    if args.json not in (None, "-"):
        check_output(Path(args.json), "JSON")  # before any tracking
    profiles = profiles_of(args)
    loaded: dict[str, Profile] = {}
    for name in profiles:
        try:
            loaded[name] = load_profile(name)  # before any tracking
        except ValueError as exc:
            raise RobotError(f"--profile {name}: {exc}") from None
    calibration = performer_calibration(getattr(args, "calibration", None))
    live = driver_given(args) or camera_given(args)
    ways = [flag for flag in ("closed_loop", "planned") if getattr(args, flag, False)]
    for flag in ways:
        _check_variant(flag, loaded, live, args.learn_poses is not None)
    if args.learn_poses is not None:
        _check_learn(args.learn_poses, live)

    def progress(what: str) -> None:
        print(f"bench robot: {what}", file=sys.stderr, flush=True)

    if live:
        result = _live(args, profiles, progress, calibration, closed="closed_loop" in ways)
    else:
        stray = rig_flags_given(args, RIG)
        if stray:
            raise OptionError(f"{stray[0]} goes with --driver (a head outside this process)")
        heads, open_head = simulated_heads(args.head)
        learn = _learner(args.learn_poses) if args.learn_poses is not None else None
        progress("tracking the performer")
        performance = track_performer(
            args.video or str(sample_video()), frames=args.frames, calibration=calibration
        )
        if ways:
            from .robot_variants import bench_variants

            result = bench_variants(
                performance,
                heads,
                profiles,
                open_head,
                dict(_variant(flag) for flag in ways),
                progress=progress,
                learn=learn,
            )
        else:
            result = bench_robot(
                performance, heads, profiles, open_head, progress=progress, learn=learn
            )
    text = json.dumps(robot_json(result), indent=2)
    if args.json == "-":
        print(text)
        return 0
    if args.json:
        write_atomic(args.json, text + "\n", mode=0o644)
    print(format_robot(result))
    return 0


def _check_variant(flag: str, profiles: dict[str, Profile], live: bool, learning: bool) -> None:
    """``--closed-loop`` / ``--planned``: simulated heads in process, and a learned profile to
    run that way (one of ``profiles``, loaded by name, or one ``--learn-poses`` learns), each
    learned one with the ``poly_ridge`` self-model both go through (checked before the
    performer is tracked)."""
    from facesynth.runtime.profiles.learned import PolyRidge

    option = "--" + flag.replace("_", "-")
    verb = {"closed_loop": "closes the loop on", "planned": "plays plans to"}[flag]
    if live and flag != "closed_loop":
        raise OptionError(f"{option} drives the simulated heads in process; omit --driver")
    learned = [(name, p.learned) for name, p in profiles.items() if p.learned is not None]
    if not learning and not learned:
        raise OptionError(
            f"{option} needs a learned --profile (e.g. runs/head.learned) or --learn-poses "
            f"(it {verb} learned profiles only)"
        )
    for name, mapping in learned:
        if not isinstance(mapping.forward, PolyRidge):
            raise OptionError(
                f"{option}: profile {name} has no poly_ridge self-model (it {verb} learned "
                "profiles through theirs; facesynth learn writes one)"
            )


def _variant(flag: str) -> tuple[str, Runner]:
    """The suffix and runner of ``--closed-loop`` or ``--planned``."""
    if flag == "closed_loop":
        from .robot_closed import CLOSED_SUFFIX, closed_runner

        return CLOSED_SUFFIX, closed_runner()
    from .robot_planned import PLANNED_SUFFIX, run_planned

    return PLANNED_SUFFIX, run_planned


def _check_learn(poses: int, live: bool) -> None:
    """``--learn-poses N``: simulated heads in process, enough poses, scikit-learn."""
    from facesynth.app.learn.inprocess import MIN_POSES
    from facesynth.app.learn.models import require_sklearn

    if live:
        raise OptionError(
            "--learn-poses babbles the simulated heads in process; with --driver, learn with "
            "facesynth learn and pass the result as --profile"
        )
    if poses < MIN_POSES:
        raise OptionError(f"--learn-poses must be at least {MIN_POSES} (got {poses})")
    require_sklearn()  # before any tracking


def _learner(poses: int) -> Callable[[str], list[Profile]]:
    """A profile learned for a simulated head (by name) from ``poses`` babbled poses of it,
    on the hardware profile that has its servos
    (:func:`~facesynth.app.learn.inprocess.hardware_for`)."""
    from facesynth.app.learn.inprocess import learn_simhead

    def learn(head: str) -> list[Profile]:
        return [learn_simhead(head, poses)]

    return learn


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
    return camera, driver, f"{_where(driver)} | {_where(camera)}"


def _where(config: msgspec.Struct) -> str:
    """A plugin config as the report names it: its plugin and, if it has them, the place it
    reads or writes (a port, a bus, a camera, a topic)."""
    data = msgspec.to_builtins(config)
    places = ("port", "bus", "index", "topic")
    return " ".join(str(data[k]) for k in (next(iter(data)), *places) if data.get(k) is not None)


def _live(
    args: argparse.Namespace,
    profiles: list[str],
    progress: Callable[[str], None],
    calibration: Calibration | None = None,
    *,
    closed: bool = False,
) -> RobotBench:
    """Every profile on the head behind ``--driver`` (any servo driver, with its options),
    watched through ``--camera`` (or the robot's camera on ROS 2, ``--ros2-image-topic``);
    with ``closed``, each learned one again with T's loop closed through that camera."""
    from facesynth.app.data import sample_video
    from facesynth.app.robot_rig import preflight
    from facesynth.runtime.profiles import load_profile
    from facesynth.runtime.service import run_async
    from facesynth.services.control.drivers.registry import DRIVERS
    from facesynth.services.sensor.sources.registry import SOURCES

    from .robot_closed import CLOSED_SUFFIX
    from .robot_live import CameraFeed, live_closed, live_profile

    camera, driver, name = head_rig(args)
    first = load_profile(profiles[0])
    if DRIVERS.build(driver, first).moves_hardware:  # a board that is not there: said now
        run_async(preflight(driver, first))
    source = SOURCES.build(camera)  # a camera that cannot open: before any tracking
    if not source.info.live:
        source.close()
        raise OptionError(
            f"source {_where(camera)} is not a live camera: bench robot watches the head as "
            "it moves (--camera or --ros2-image-topic)"
        )
    feed = CameraFeed(source)
    try:
        progress("tracking the performer")
        performance = track_performer(
            args.video or str(sample_video()), frames=args.frames, calibration=calibration
        )

        def run(head: str, profile: Profile) -> FeatureStream:
            if profile.name.endswith(CLOSED_SUFFIX):
                profile = msgspec.structs.replace(
                    profile, name=profile.name.removesuffix(CLOSED_SUFFIX)
                )
                output = DRIVERS.build(driver, profile)
                return asyncio.run(live_closed(performance, profile, output, feed))[0]
            output = DRIVERS.build(driver, profile)
            return asyncio.run(live_profile(performance, profile, output, feed))

        ways = [CLOSED_SUFFIX] if closed else []
        every = [way for profile in profiles for way in every_way(load(profile), ways)]
        return measure(performance, [name], every, run, progress=progress)
    finally:
        feed.close()
