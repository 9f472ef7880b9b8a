"""From a graph node (and its plugin config) to a running stage: sources, backends, cores, drivers.

:func:`build_node` hands a node to its stage's build function, found in the stage registry
(:mod:`facesynth.app.stages`), with the chain's settled :class:`~facesynth.app.stages.setup.Setup`;
the builders of each stage live with its descriptor and are named here for the tools that build
one part alone (the renderer, calibration, the console).

Every builder raises a ``ValueError`` subclass with a clear message for bad options or files;
the CLI prints it and exits with status 2.
"""

from __future__ import annotations

import argparse
from typing import Any

import msgspec

from facesynth.app.arguments import OptionError
from facesynth.app.graph import Graph, plugin_config
from facesynth.app.nodes import ControlNode, TranslatorNode
from facesynth.app.profile_choice import settle
from facesynth.app.router_wait import ONE_SHOT_WAIT_S, RouterWait, kind_of
from facesynth.app.stages.calibration import build_calibration
from facesynth.app.stages.control import control_service
from facesynth.app.stages.descriptor import NodeBuild, ServiceBody, StageParts
from facesynth.app.stages.features import build_processor, state_keeping
from facesynth.app.stages.points import build_backend
from facesynth.app.stages.registry import STAGES
from facesynth.app.stages.sensor import build_source, sensor_options
from facesynth.app.stages.setup import Setup, build_profile
from facesynth.runtime.bus.zenoh_bus import DEFAULT_ROUTER, ZenohOptions, endpoints
from facesynth.runtime.feature_names import BLENDSHAPE_NAMES
from facesynth.services.control.service import ControlService
from facesynth.services.points.backends.base import PointsBackend, Replay
from facesynth.services.points.backends.registry import BACKENDS
from facesynth.services.translator.core import Translator

__all__ = [
    "OptionError",
    "ServiceBody",
    "StageParts",
    "build_backend",
    "build_calibration",
    "build_control",
    "build_node",
    "build_processor",
    "build_profile",
    "build_source",
    "build_translator",
    "check_blendshapes",
    "replay_frames_of",
    "sensor_options",
    "state_keeping",
    "zenoh_options",
]


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


def build_translator(node: TranslatorNode, setup: Setup | None = None) -> Translator:
    """The translator of a node: its profile (the chain's settled one from ``setup`` if given,
    else read now) and calibration."""
    if setup is not None:
        profile = setup.profile(node.profile, node.mirror)
    else:
        profile = build_profile(node.profile, node.mirror)
    return Translator(profile, build_calibration(node.calibration))


def build_control(node: ControlNode, driver: msgspec.Struct, fast: bool = False) -> ControlService:
    """The control interface of a node, with its driver and its profile (read now); see
    :func:`facesynth.app.stages.control.control_service`."""
    return control_service(node, driver, build_profile(node.profile, node.mirror), fast)


def build_node(
    name: str,
    node: Any,
    graph: Graph,
    config: msgspec.Struct | None = None,
    *,
    replay_frames: int | None = None,
    fast: bool | None = None,
    standalone: bool = False,
    setup: Setup | None = None,
) -> StageParts:
    """The running form of ``graph.nodes[name]`` (``node``, perhaps overridden), built by its
    stage's descriptor (:mod:`facesynth.app.stages`).

    ``config`` is the node's plugin config if already validated (else the setup's, else read
    from the node); ``replay_frames`` the length of a replayed point stream in the chain, if
    any; ``fast`` whether the chain's input comes faster than real time (default: the setup
    says, from the graph's sensor); ``standalone`` whether the node runs as a service of its
    own (``facesynth STAGE``); ``setup`` the chain's settled setup
    (:func:`facesynth.app.profile_choice.settle`), else settled here for this node alone,
    naming profiles as the node does.
    """
    if setup is None:
        configs = {name: config} if config is not None else None
        setup = settle(graph, configs, check=False, fill=False, plugins=False)
    config = config or setup.configs.get(name) or plugin_config(node, f"node {name}")
    try:
        stage = STAGES.of(node)
    except ValueError as exc:
        raise OptionError(f"node {name}: {exc}") from None
    request = NodeBuild(
        name,
        node,
        config,
        setup,
        replay_frames=replay_frames,
        fast=setup.fast if fast is None else fast,
        standalone=standalone,
    )
    return stage.build(request)


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
    for name, node in graph.nodes.items():
        table = STAGES.of(node).plugin
        if table is None or table.registry is not BACKENDS:
            continue
        config = plugin_config(node, f"node {name}")
        factory = BACKENDS.get(str(config.__struct_config__.tag)).factory if config else None
        if config is not None and isinstance(factory, type) and issubclass(factory, Replay):
            return BACKENDS.build(config).frame_count()
    return None
