"""Turn command-line options into the parts of the chain (sources, backends, cores, drivers).

Every builder raises a ``ValueError`` subclass with a clear message for bad options or files;
the CLI prints it and exits with status 2.
"""

from __future__ import annotations

import argparse

from facesynth.app.data import sample_video
from facesynth.runtime.bus.zenoh_bus import DEFAULT_ROUTER, ZenohOptions, endpoints
from facesynth.runtime.calibration import Calibration, load_calibration
from facesynth.runtime.profiles import Profile, load_profile
from services.control.drivers.base import ServoDriver
from services.control.drivers.config import (
    DriverConfigError,
    RecordConfig,
    load_driver_config,
    make_driver,
)
from services.features.core import FeatureProcessor
from services.points.backends import OpenFaceReplay, PointsBackend, TrackReplay
from services.sensor.service import SensorOptions
from services.sensor.sources import (
    CameraSource,
    FolderSource,
    FrameSource,
    SourceError,
    TickSource,
    VideoSource,
)
from services.translator.core import Translator


class OptionError(ValueError):
    """Options that do not fit together."""


def zenoh_options(args: argparse.Namespace, *, default_mode: str = "client") -> ZenohOptions:
    """Zenoh options from ``--mode/--connect/--listen/--zenoh-config/--scouting``.

    A config file (``--zenoh-config`` or ``$ZENOH_CONFIG``) keeps its own mode and endpoints
    unless options override them; without one, a client connects to the default local router.
    Clients send everything through the router: one fixed path per message, so nothing is lost
    while peers would be opening direct links to each other mid-stream.
    """
    options = ZenohOptions(
        mode=args.mode,
        connect=endpoints(args.connect),
        listen=endpoints(args.listen),
        config_file=args.zenoh_config,
        scouting=args.scouting,
    )
    if options.config_file_path() is None:
        options.mode = options.mode or default_mode
        if options.mode != "router" and not options.connect and not options.listen:
            options.connect = [DEFAULT_ROUTER]
    return options


#: The options that name a frame source; at most one may be given.
SOURCE_OPTIONS = ("video", "camera", "images", "ticks")


def named_sources(args: argparse.Namespace) -> list[str]:
    """The frame source options given on the command line."""
    return [name for name in SOURCE_OPTIONS if getattr(args, name, None) is not None]


def has_source(args: argparse.Namespace) -> bool:
    """Whether a frame source was named."""
    return bool(named_sources(args))


def build_source(args: argparse.Namespace, replay_frames: int | None = None) -> FrameSource:
    """The frame source named by ``--video/--camera/--images/--ticks``.

    Without one: ticks for a replayed point stream (``replay_frames``), else the bundled video.
    """
    chosen = named_sources(args)
    if len(chosen) > 1:
        raise OptionError(f"choose one frame source, not {' and '.join('--' + c for c in chosen)}")
    fps = getattr(args, "fps", None)
    loop = bool(getattr(args, "loop", False))
    if args.video is not None:
        return VideoSource(args.video, loop=loop, fps=fps)
    if args.camera is not None:
        return CameraSource(args.camera, fps=fps or 0.0)
    if args.images is not None:
        return FolderSource(args.images, fps=fps or 30.0, loop=loop)
    if getattr(args, "ticks", None) is not None:
        return TickSource(args.ticks, fps=fps or 30.0)
    if replay_frames is not None:
        return TickSource(replay_frames, fps=fps or 30.0)
    path = sample_video()
    if not path.is_file():
        raise SourceError(f"the bundled sample video is missing ({path}); pass --video")
    return VideoSource(path, loop=loop, fps=fps)


def sensor_options(args: argparse.Namespace, wait_for: list[str] | None = None) -> SensorOptions:
    """Sensor pacing and encoding options."""
    if args.window < 1:
        raise OptionError("--window must be at least 1")
    if not 1 <= args.quality <= 100:
        raise OptionError("--quality must be 1..100")
    return SensorOptions(
        fast=args.fast,
        window=args.window,
        encoding=args.encoding,
        quality=args.quality,
        max_frames=args.max_frames,
        wait_for=wait_for if wait_for is not None else endpoints(args.wait_for),
        wait_timeout=getattr(args, "wait_timeout", 10.0),
    )


def build_backend(args: argparse.Namespace) -> PointsBackend:
    """The point streamer backend: a replay when a recording is given, else the tracker."""
    loop = bool(getattr(args, "loop_replay", False))
    if args.openface_csv and args.points_jsonl:
        raise OptionError("give --openface-csv or --points-jsonl, not both")
    if args.openface_csv:
        return OpenFaceReplay(args.openface_csv, loop=loop)
    if args.points_jsonl:
        return TrackReplay(args.points_jsonl, loop=loop)
    from services.points.tracking import TrackerBackend  # OpenCV and the models: tracker hosts

    if not 1 <= args.threads <= 64:
        raise OptionError("--threads must be 1..64")
    if args.redetect_every < 1:
        raise OptionError("--redetect-every must be at least 1")
    return TrackerBackend(
        backend=args.inference,
        model=args.model,
        blendshapes=args.blendshapes,
        num_threads=args.threads,
        select=args.select,
        redetect_every=args.redetect_every,
    )


def build_calibration(args: argparse.Namespace) -> Calibration | None:
    """The calibration named by ``--calibration``, if any."""
    return load_calibration(args.calibration) if args.calibration else None


def build_profile(args: argparse.Namespace) -> Profile:
    """The profile named by ``--profile``, with ``--mirror`` applied."""
    profile = load_profile(args.profile)
    if getattr(args, "mirror", False):
        profile.mirror = not profile.mirror
    return profile


def build_processor(
    args: argparse.Namespace, calibration: Calibration | None, profile: Profile | None = None
) -> FeatureProcessor:
    """The feature processor, with the calibration's neutral when there is one."""
    seconds = args.neutral_seconds
    if seconds is None:
        seconds = profile.neutral_seconds if profile is not None else 1.0
    if not seconds > 0:
        raise OptionError("--neutral-seconds must be positive")
    auto = bool(getattr(args, "auto_range", False))
    if calibration is not None:
        return FeatureProcessor.from_calibration(
            calibration, neutral_seconds=seconds, auto_range=auto
        )
    return FeatureProcessor(neutral_seconds=seconds, auto_range=auto)


def build_translator(profile: Profile, calibration: Calibration | None) -> Translator:
    """The translator for a profile and optional calibration."""
    return Translator(profile, calibration)


def build_driver(args: argparse.Namespace) -> ServoDriver:
    """The servo driver from ``--driver-config FILE`` or ``--driver NAME`` options."""
    if args.driver_config:
        return make_driver(load_driver_config(args.driver_config))
    if args.driver == "record":
        if not args.out:
            raise DriverConfigError("--driver record needs --out FILE.jsonl")
        return make_driver(RecordConfig(out=args.out))
    raise DriverConfigError(f"unknown driver {args.driver!r}")
