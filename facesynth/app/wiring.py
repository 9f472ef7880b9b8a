"""From a graph node (and its plugin config) to a running stage: sources, backends, cores, drivers.

Every builder raises a ``ValueError`` subclass with a clear message for bad options or files;
the CLI prints it and exits with status 2.
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgspec

from facesynth.app.data import sample_video
from facesynth.app.graph import Graph, plugin_config
from facesynth.app.nodes import (
    DEFAULT_PROFILE,
    ControlNode,
    FeaturesNode,
    PointsNode,
    SensorNode,
    TranslatorNode,
    stage_of,
)
from facesynth.app.profile_choice import check_fit
from facesynth.app.router_wait import ONE_SHOT_WAIT_S, RouterWait, kind_of
from facesynth.runtime.bus.zenoh_bus import DEFAULT_ROUTER, ZenohOptions, endpoints
from facesynth.runtime.calibration import Calibration, load_calibration, resolve_calibration
from facesynth.runtime.feature_names import BLENDSHAPE_NAMES
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.runtime.service import ServiceContext
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.service import ControlService
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.service import StateKeeping, serve_features
from facesynth.services.features.state import StateError
from facesynth.services.features.state import check_name as check_state_name
from facesynth.services.points.backends.base import PointsBackend, Replay
from facesynth.services.points.backends.registry import BACKENDS
from facesynth.services.points.service import serve_points
from facesynth.services.sensor.service import SensorOptions, SensorService
from facesynth.services.sensor.sources.base import FrameSource, SourceError
from facesynth.services.sensor.sources.registry import SOURCES
from facesynth.services.sensor.sources.ticks import TicksConfig
from facesynth.services.sensor.sources.video import VideoConfig
from facesynth.services.translator.core import Translator
from facesynth.services.translator.service import serve_translator

ServiceBody = Callable[[ServiceContext], Awaitable[Any]]


class OptionError(ValueError):
    """Options or nodes that do not fit together."""


#: How a service retries its router while waiting for it (Zenoh's connect/retry, in ms).
ROUTER_RETRY = {"period_init_ms": 100, "period_max_ms": 1000, "period_increase_factor": 2}


def zenoh_options(
    args: argparse.Namespace, *, default_mode: str = "client", wait_for_router: bool = False
) -> ZenohOptions:
    """Zenoh options from ``--mode/--connect/--listen/--zenoh-config/--scouting``.

    A config file (``--zenoh-config`` or ``$ZENOH_CONFIG``) keeps its own mode and endpoints
    unless options override them; without one, a client connects to the default local router.
    Clients send everything through the router: one fixed path per message, so nothing is lost
    while peers would be opening direct links to each other mid-stream.

    How long a client waits for its router follows the command's kind
    (:mod:`facesynth.app.router_wait`, from ``args.command``; ``wait_for_router``: a service):
    a service started before its router waits for it, retrying with backoff (0.1 s, doubling up
    to 1 s), as ``timeout_ms: -1`` does in the ``deploy/`` configs; a one-shot tool waits at
    most :data:`~facesynth.app.router_wait.ONE_SHOT_WAIT_S`. ``--router-timeout S`` bounds
    either wait (0: fail at once), and also applies over a config file's own setting.
    """
    options = ZenohOptions(
        mode=args.mode,
        connect=endpoints(args.connect),
        listen=endpoints(args.listen),
        config_file=args.zenoh_config,
        scouting=args.scouting,
    )
    timeout = getattr(args, "router_timeout", None)
    kind = RouterWait.WAITS if wait_for_router else kind_of(getattr(args, "command", None))
    if options.config_file_path() is None:
        options.mode = options.mode or default_mode
        if options.mode != "router" and not options.connect and not options.listen:
            options.connect = [DEFAULT_ROUTER]
        if kind is RouterWait.WAITS and options.mode == "client" and timeout is None:
            timeout = -1.0
    if kind is RouterWait.ONE_SHOT and timeout is None and options.effective_mode() != "router":
        timeout = ONE_SHOT_WAIT_S  # whatever a config file says: a one-shot tool never hangs
    if kind in (RouterWait.WAITS, RouterWait.ONE_SHOT) and timeout is not None:
        options.overrides.update(
            {
                "connect/timeout_ms": -1 if timeout < 0 else round(timeout * 1000),
                "connect/exit_on_failure": False,
                "connect/retry": dict(ROUTER_RETRY),
            }
        )
    return options


def build_source(config: msgspec.Struct, replay_frames: int | None = None) -> FrameSource:
    """The frame source of a config; the bundled video when a video source names no file.

    With a replayed point stream (``replay_frames``) and no video named, ticks drive the chain.
    """
    if isinstance(config, VideoConfig) and config.path is None:
        if replay_frames is not None:
            return SOURCES.build(TicksConfig(count=replay_frames, fps=config.fps))
        path = sample_video()
        if not path.is_file():
            raise SourceError(f"the bundled sample video is missing ({path}); pass --video")
        config = msgspec.structs.replace(config, path=str(path))
    return SOURCES.build(config)


def build_backend(config: msgspec.Struct) -> PointsBackend:
    """The points backend of a config (the tracker loads its models here)."""
    return BACKENDS.build(config)


def build_profile(name: str | None, mirror: bool) -> Profile:
    """The profile called ``name``, mirrored when ``mirror`` (which flips the profile's own);
    ``None`` (a node whose profile was not settled by :func:`settle_profiles`) is the default."""
    profile = load_profile(name or DEFAULT_PROFILE)
    if mirror:
        profile.mirror = not profile.mirror
    return profile


#: Calibration files already confirmed in the log (F and T of one process load the same one).
_CONFIRMED: set[Path] = set()


def build_calibration(name: str | None) -> Calibration | None:
    """The calibration called ``name``, if any; the file it came from, the performer and when it
    was made are logged once per process (logger ``facesynth.calibration``)."""
    if not name:
        return None
    calibration = load_calibration(name)
    path = resolve_calibration(name).resolve()
    if path not in _CONFIRMED:
        _CONFIRMED.add(path)
        logging.getLogger("facesynth.calibration").info(
            "calibration %s: %s (performer %s, made %s)",
            name,
            path,
            calibration.name,
            calibration.created or "at an unrecorded time",
        )
    return calibration


def build_processor(node: FeaturesNode, default_neutral_s: float = 1.0) -> FeatureProcessor:
    """The feature processor, with the calibration's neutral when there is one."""
    seconds = node.neutral_seconds if node.neutral_seconds is not None else default_neutral_s
    calibration = build_calibration(node.calibration)
    if calibration is not None:
        return FeatureProcessor.from_calibration(
            calibration, neutral_seconds=seconds, auto_range=node.auto_range
        )
    return FeatureProcessor(
        neutral_seconds=seconds, auto_range=node.auto_range, neutral_held=node.neutral_held
    )


def state_keeping(node: FeaturesNode, standalone: bool) -> StateKeeping | None:
    """Whether and where F keeps its learned neutral: not with a calibration; by default only
    for a service of its own (a one-process ``run`` or ``replay`` starts its input afresh)."""
    keep = node.keep_state if node.keep_state is not None else standalone
    if not keep or node.calibration:
        return None
    try:
        check_state_name(node.performer, "performer")
    except StateError as exc:
        raise OptionError(str(exc)) from None
    return StateKeeping(node.performer, node.state_dir, node.relearn)


def build_translator(node: TranslatorNode) -> Translator:
    """The translator of a node: its profile and calibration."""
    return Translator(build_profile(node.profile, node.mirror), build_calibration(node.calibration))


def build_control(node: ControlNode, driver: msgspec.Struct, fast: bool = False) -> ControlService:
    """The control interface of a node, with its driver.

    Speed limits are measured on media time only for a ``--fast`` chain (``fast``) or when
    asked, and never for a driver that moves hardware.
    """
    profile = build_profile(node.profile, node.mirror)
    check_fit(driver, profile)
    output = DRIVERS.build(driver, profile)
    motion_time = node.motion_time
    if motion_time == "media" and output.moves_hardware:
        raise OptionError(
            f"--motion-time media measures speed limits on the commands' media time, which "
            f"is not for the {driver.__struct_config__.tag} driver: it moves a real head"
        )
    if motion_time is None:
        motion_time = "media" if fast and not output.moves_hardware else "real"
    return ControlService(
        profile, output, watchdog_s=node.watchdog, queue=node.queue, motion_time=motion_time
    )


def sensor_options(node: SensorNode) -> SensorOptions:
    """The sensor's pacing and encoding options."""
    return SensorOptions(
        fast=node.fast,
        window=node.window,
        encoding=node.encoding,
        quality=node.quality,
        max_frames=node.max_frames,
        wait_for=list(node.wait_for),
        wait_timeout=node.wait_timeout,
        capture_age=node.capture_age,
    )


@dataclass
class StageParts:
    """What one node became: its service body, and the objects a runner may look at."""

    name: str
    stage: str
    body: ServiceBody
    service: Any = None
    #: The robot whose command keys the node uses (a rig driving several robots), if any.
    robot: str | None = None


def build_node(
    name: str,
    node: Any,
    graph: Graph,
    config: msgspec.Struct | None = None,
    *,
    replay_frames: int | None = None,
    fast: bool | None = None,
    standalone: bool = False,
) -> StageParts:
    """The running form of ``graph.nodes[name]`` (``node``, perhaps overridden).

    ``config`` is the node's plugin config if already validated (else read from the node);
    ``replay_frames`` the length of a replayed point stream in the chain, if any; ``fast``
    whether the chain's input comes faster than real time (default: the graph's sensor says);
    ``standalone`` whether the node runs as a service of its own (``facesynth STAGE``).
    """
    stage = stage_of(node)
    config = config or plugin_config(node, f"node {name}")
    if isinstance(node, SensorNode):
        assert config is not None
        source = build_source(config, replay_frames)
        sensor = SensorService(source, sensor_options(node))
        return StageParts(name, stage, sensor.serve, sensor)
    if isinstance(node, PointsNode):
        assert config is not None
        backend = build_backend(config)
        return StageParts(name, stage, lambda ctx: serve_points(ctx, backend, node.queue), backend)
    if isinstance(node, FeaturesNode):
        processor = build_processor(node, _profile_neutral_seconds(graph, node))
        keeping = state_keeping(node, standalone)
        return StageParts(
            name,
            stage,
            lambda ctx: serve_features(ctx, processor, node.queue, keeping),
            processor,
        )
    if isinstance(node, TranslatorNode):
        translator = build_translator(node)
        return StageParts(
            name,
            stage,
            lambda ctx: serve_translator(ctx, translator, node.queue),
            translator,
            robot=node.robot,
        )
    if isinstance(node, ControlNode):
        assert config is not None
        if fast is None:
            fast = any(sensor.fast for sensor in graph.of_stage("sensor").values())
        control = build_control(node, config, fast)
        return StageParts(name, stage, control.serve, control, robot=node.robot)
    raise OptionError(f"node {name}: unknown stage {stage!r}")


def check_blendshapes(parts: list[StageParts]) -> None:
    """Refuse a chain whose profile is driven by blendshapes that no points backend gives
    (the ``fast`` tracker model, ``--no-blendshapes``, a replay without them): its servos would
    silently stay at neutral."""
    backends = [p.service for p in parts if isinstance(p.service, PointsBackend)]
    if not backends or any(b.gives_blendshapes() for b in backends):
        return
    for part in parts:
        if isinstance(part.service, Translator):
            profile = part.service.profile
            named = {n for spec in profile.servos for n in spec.weights() or {}}
            if profile.learned is not None:
                named.update(profile.learned.inputs)
            used = sorted(named & BLENDSHAPE_NAMES)
            if used:
                shown = ", ".join(used[:3]) + (", …" if len(used) > 3 else "")
                raise OptionError(
                    f"profile {profile.name} is driven by blendshapes ({shown}), which the points "
                    "backend does not give: use the tracker with --model full (and blendshapes)"
                )


def replay_frames_of(graph: Graph) -> int | None:
    """Frames of a replayed point stream in the graph (ticks then drive the chain), if any."""
    for name, node in graph.of_stage("points").items():
        config = plugin_config(node, f"node {name}")
        factory = BACKENDS.get(str(config.__struct_config__.tag)).factory if config else None
        if config is not None and isinstance(factory, type) and issubclass(factory, Replay):
            return BACKENDS.build(config).frame_count()
    return None


def _profile_neutral_seconds(graph: Graph, node: FeaturesNode) -> float:
    """F's neutral window without a calibration: the translator profile's, else 1 s."""
    for translator in graph.of_stage("translator").values():
        return build_profile(translator.profile, False).neutral_seconds
    return 1.0
